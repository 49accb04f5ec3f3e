"""Named layouts of the flat float64 arrays the compiled kernels read.

A kernel array (a plant's ``theta``, a link array) is addressed by slot number inside
:mod:`simgap.models` only, and those numbers are generated here from field names, never
written by hand. Kernel modules bind the slots to module-level ints
(``MU = PLANT["mu"]``): numba freezes module-level ints as compile-time constants, so a
generated slot costs nothing over a literal, and inserting a field renumbers every reader.

A layout is a sequence of blocks. A block is either one scalar field (``"mu"``) or a
per-channel row block ``("friction", ("fc", "sigma", ...), 2)``: ``count`` rows of the
same fields, row-major, so that channel i's field f sits at
``layout["friction"] + i * layout.stride("friction") + layout.field("friction", "f")``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

Block = str | tuple[str, Sequence[str], int]


@dataclass(frozen=True)
class _Rows:
    start: int
    fields: tuple[str, ...]
    count: int


class Slots:
    """Field names → slot numbers of one kernel array.

    Args:
        *blocks: scalar field names, or ``(name, fields, count)`` row blocks.

    Raises:
        ValueError: on a repeated name or an empty row block.
    """

    def __init__(self, *blocks: Block) -> None:
        self._scalar: dict[str, int] = {}
        self._rows: dict[str, _Rows] = {}
        names: list[str] = []
        pos = 0
        for b in blocks:
            if isinstance(b, str):
                self._claim(b)
                self._scalar[b] = pos
                names.append(b)
                pos += 1
                continue
            name, fields, count = b[0], tuple(b[1]), int(b[2])
            if not fields or count < 1 or len(set(fields)) != len(fields):
                raise ValueError(f"row block {name!r} needs distinct fields and count >= 1")
            self._claim(name)
            self._rows[name] = _Rows(pos, fields, count)
            names += [f"{name}[{i}].{f}" for i in range(count) for f in fields]
            pos += len(fields) * count
        self.size = pos
        self.names = tuple(names)

    def _claim(self, name: str) -> None:
        if name in self._scalar or name in self._rows:
            raise ValueError(f"slot name {name!r} appears twice")

    def __getitem__(self, name: str) -> int:
        """Slot of a scalar field, first slot of a row block, or ``"block.field"`` of row 0."""
        if name in self._scalar:
            return self._scalar[name]
        if name in self._rows:
            return self._rows[name].start
        block, _, fld = name.partition(".")
        if block in self._rows and fld:
            return self._rows[block].start + self.field(block, fld)
        raise KeyError(f"no slot {name!r}; known: {sorted([*self._scalar, *self._rows])}")

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (name in self._scalar or name in self._rows)

    def stride(self, block: str) -> int:
        """Slots per row of a row block (the distance from channel i to channel i + 1)."""
        return len(self._rows[block].fields)

    def count(self, block: str) -> int:
        """Rows (channels) of a row block."""
        return self._rows[block].count

    def field(self, block: str, name: str) -> int:
        """Offset of ``name`` inside one row of ``block``."""
        fields = self._rows[block].fields
        if name not in fields:
            raise KeyError(f"row block {block!r} has no field {name!r}; fields: {fields}")
        return fields.index(name)

    def prefix_of(self, other: Slots) -> bool:
        """True when this layout's names open ``other`` (e.g. the nominal array the plant's)."""
        return other.names[:len(self.names)] == self.names

    def __repr__(self) -> str:
        return f"Slots({self.size} slots: {', '.join(self.names)})"


def field_index(fields: Sequence[str], name: str) -> int:
    """Column of ``name`` in a fields tuple (for 2-D per-channel arrays such as friction)."""
    return tuple(fields).index(name)
