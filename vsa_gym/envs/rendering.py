"""Rendering: the mechanism drawn schematically next to the recent traces (matplotlib, Agg canvas).

``render_mode="rgb_array"`` returns an ``(H, W, 3)`` ``uint8`` array (``TaskEnv.render_size``);
``"human"`` shows the same picture in a matplotlib window (nothing is shown with a
non-interactive backend).  Rendering never runs inside ``step``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vsa_gym.envs.task import BatchedTask

DPI = 100


class Renderer:
    """Draws one row of a task: mechanism on the left, traces (grouped) on the right."""

    def __init__(self, size: tuple[int, int], title: str = "") -> None:
        self.height, self.width = size
        self.title = title
        self._window: Any = None

    def draw(self, task: BatchedTask, i: int) -> np.ndarray:
        fig = Figure(figsize=(self.width / DPI, self.height / DPI), dpi=DPI)
        canvas = FigureCanvasAgg(fig)
        groups = task.trace_groups or tuple((k,) for k in range(len(task.trace_names)))
        gs = fig.add_gridspec(max(1, len(groups)), 2, width_ratios=(1.0, 1.3), left=0.04, right=0.98,
                              top=0.92, bottom=0.08, wspace=0.25, hspace=0.45)
        ax_m = fig.add_subplot(gs[:, 0])
        ax_m.set_aspect("equal")
        ax_m.set_xticks([])
        ax_m.set_yticks([])
        task.draw_mechanism(ax_m, i)
        t_now = float(task.s["t"][i])
        fig.suptitle(f"{self.title}  t = {t_now:.3f} s", fontsize=10)
        hist = task.history(i)
        k = hist.shape[0]
        t = t_now - task.control_dt * np.arange(k - 1, -1, -1)
        for g, idx in enumerate(groups):
            ax = fig.add_subplot(gs[g, 1])
            for j in idx:
                ax.plot(t, hist[:, j], lw=1.0, label=f"{task.trace_names[j]} [{task.trace_units[j]}]")
            ax.legend(fontsize=6, loc="upper left")
            ax.tick_params(labelsize=6)
            ax.grid(alpha=0.3)
        canvas.draw()
        frame = np.asarray(canvas.buffer_rgba())[..., :3].copy()
        fig.clear()
        return frame

    def show(self, frame: np.ndarray) -> None:
        import matplotlib.pyplot as plt

        if self._window is None:
            fig, ax = plt.subplots(figsize=(self.width / DPI, self.height / DPI), dpi=DPI)
            ax.set_axis_off()
            fig.subplots_adjust(0, 0, 1, 1)
            self._window = (fig, ax.imshow(frame))
            plt.show(block=False)
        else:
            self._window[1].set_data(frame)
        self._window[0].canvas.draw_idle()
        plt.pause(1e-3)

    def close(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window[0])
            self._window = None
