"""Pure dynamics kernels and nominal models (no gymnasium, no plotting)."""

from simgap.models.base import BaseNominalModel, MechanicalNominalModel, NominalModel
from simgap.models.bicycle import BicycleNominal, BicycleParams
from simgap.models.friction import FRICTION_MODELS, FrictionParams
from simgap.models.manipulator import JointDisturbance, ManipulatorNominal, ManipulatorParams
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams
from simgap.models.tires import MagicFormulaTire

__all__ = [
    "FRICTION_MODELS",
    "BaseNominalModel",
    "BicycleNominal",
    "BicycleParams",
    "FrictionParams",
    "JointDisturbance",
    "MagicFormulaTire",
    "ManipulatorNominal",
    "ManipulatorParams",
    "MechanicalNominalModel",
    "NominalModel",
    "RigidAxisNominal",
    "RigidAxisParams",
]
