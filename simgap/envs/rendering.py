"""``rgb_array`` frames of the envs, drawn with matplotlib's Agg canvas (no display needed).

Renderers build their figure once and only move artists per frame; they hold no physics: the
env passes the quantities to draw. Frames are HxWx3 uint8 arrays.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrow, Polygon


class _AggRenderer:
    """A figure of ``size`` pixels on an Agg canvas."""

    def __init__(self, size: int = 400) -> None:
        self.fig = Figure(figsize=(size / 100.0, size / 100.0), dpi=100)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.17, 0.12, 0.78, 0.72))

    def _square_view(self, half: float, xlabel: str, ylabel: str) -> None:
        """Equal-aspect axes spanning [−half, half] in both directions (m), gridded."""
        ax = self.ax
        ax.set_xlim(-half, half)
        ax.set_ylim(-half, half)
        ax.set_aspect("equal")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)

    def frame(self) -> np.ndarray:
        """Rasterise the figure to an HxWx3 uint8 array."""
        self.canvas.draw()
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        """Release the figure."""
        self.fig.clear()


class ArmRenderer(_AggRenderer):
    """Side view of the two-link arm in its vertical plane (gravity along −y).

    Args:
        l1: length of link 1 (m).
        l2: length of link 2 (m), drawn to the tip.
        size: frame width and height (pixels).
    """

    def __init__(self, l1: float, l2: float, size: int = 400) -> None:
        super().__init__(size)
        self.l1, self.l2 = float(l1), float(l2)
        self._square_view(1.15 * (self.l1 + self.l2), "x (m)", "y (m)")
        ax = self.ax
        (self._ref_line,) = ax.plot([], [], "--o", color="tab:gray", lw=2, ms=4,
                                    label="reference q_d")
        (self._arm_line,) = ax.plot([], [], "-o", color="tab:blue", lw=5, ms=8, label="arm q")
        ax.plot([0], [0], "ks", ms=10)
        ax.legend(loc="lower left", fontsize=7)
        self._title = ax.set_title("", fontsize=9)

    def _points(self, q: np.ndarray) -> tuple[list[float], list[float]]:
        x1, y1 = self.l1 * math.cos(q[0]), self.l1 * math.sin(q[0])
        x2 = x1 + self.l2 * math.cos(q[0] + q[1])
        y2 = y1 + self.l2 * math.sin(q[0] + q[1])
        return [0.0, x1, x2], [0.0, y1, y2]

    def draw(self, q: np.ndarray, q_ref: np.ndarray | None, t: float,
             tau: np.ndarray | None = None) -> np.ndarray:
        """Frame of joint angles q (rad), optional reference q_ref (rad), time t (s)."""
        self._arm_line.set_data(*self._points(q))
        if q_ref is not None:
            self._ref_line.set_data(*self._points(q_ref))
        text = f"2-DOF arm  t = {t:.3f} s"
        if tau is not None:
            text += f"\nτ = ({tau[0]:+.2f}, {tau[1]:+.2f}) N·m"
        self._title.set_text(text)
        return self.frame()


class CarRenderer(_AggRenderer):
    """Top view of the single-track car in its body frame, with axle lateral forces.

    The car points up (+x_body); arrows at the axles show the true lateral axle forces
    (solid red) and what the nominal linear tire would give (dashed gray); the blue arrow is
    the velocity (vx, vy) at the centre of gravity.

    Args:
        lf: CG to front axle (m).
        lr: CG to rear axle (m).
        force_scale: arrow length per newton (m/N).
        size: frame width and height (pixels).
    """

    def __init__(self, lf: float, lr: float, force_scale: float = 2.5e-4,
                 size: int = 400) -> None:
        super().__init__(size)
        self.lf, self.lr, self.k = float(lf), float(lr), float(force_scale)
        self._square_view(1.6 * max(lf, lr) + 1.0, "lateral y_body (m), left ←",
                          "longitudinal x_body (m)")
        ax = self.ax
        w = 0.9
        body = [(-w, -lr - 0.9), (w, -lr - 0.9), (w, lf + 0.9), (-w, lf + 0.9)]
        ax.add_patch(Polygon(self._flip(np.array(body)), closed=True, fc="0.85", ec="k"))
        (self._wheels,) = ax.plot([], [], "k-", lw=6, solid_capstyle="butt")
        self._arrows: list = []
        self._title = ax.set_title("", fontsize=9)

    @staticmethod
    def _flip(pts: np.ndarray) -> np.ndarray:
        """Body (x forward, y left) → plot (horizontal = −y so left is left, vertical = x)."""
        return np.column_stack([-pts[:, 0], pts[:, 1]]) if pts.ndim == 2 else pts

    def _arrow(self, x: float, y: float, dx: float, dy: float, **kw) -> None:
        # plot coordinates: horizontal = -y_body, vertical = x_body
        arrow = FancyArrow(-y, x, -dy, dx, width=0.05, length_includes_head=True,
                           head_width=0.25, head_length=0.25, **kw)
        self.ax.add_patch(arrow)
        self._arrows.append(arrow)

    def draw(self, vx: float, vy: float, r: float, delta: np.ndarray, forces: np.ndarray,
             forces_linear: np.ndarray, t: float) -> np.ndarray:
        """Draw one frame.

        Args:
            vx: longitudinal speed (m/s).
            vy: lateral speed (m/s).
            r: yaw rate (rad/s).
            delta: road-wheel angles (rad), front and rear.
            forces: true axle lateral forces (N).
            forces_linear: the nominal linear tire's axle forces (N).
            t: time (s).
        """
        for a in self._arrows:
            a.remove()
        self._arrows = []
        xs, ys = [], []
        half = 0.45
        for x_axle, d in ((self.lf, delta[0]), (-self.lr, delta[1])):
            c, s = math.cos(d), math.sin(d)
            xs += [half * s, -(half * s), np.nan]       # plot x = -y_body
            ys += [x_axle - half * c, x_axle + half * c, np.nan]
        self._wheels.set_data(xs, ys)
        for x_axle, f, fl in ((self.lf, forces[0], forces_linear[0]),
                              (-self.lr, forces[1], forces_linear[1])):
            self._arrow(x_axle, 0.0, 0.0, self.k * fl, color="0.5", alpha=0.6, ls="--")
            self._arrow(x_axle, 0.0, 0.0, self.k * f, color="tab:red")
        scale = 0.08
        self._arrow(0.0, 0.0, scale * vx, scale * vy * 5.0, color="tab:blue")
        self._title.set_text(f"bicycle t = {t:.2f} s  r = {r:+.3f} rad/s  vy = {vy:+.2f} m/s\n"
                             f"F_y = ({forces[0]:+.0f}, {forces[1]:+.0f}) N (red), "
                             f"linear: gray")
        return self.frame()
