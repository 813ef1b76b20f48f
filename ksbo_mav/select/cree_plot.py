"""Bar chart of C_ree per order (mean +- std over trials, exact value marked, chosen orders highlighted)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.plotting import pyplot
from ksbo_mav.select.orders import OrderSelection


def plot_cree(sel: OrderSelection, path: str | Path, title: str = "Nyström kernel selection") -> Path:
    """Write the C_ree bar chart of ``sel`` to ``path`` (PNG/PDF/SVG by suffix) and return the path."""
    plt = pyplot()
    orders = sorted(sel.mean)
    mean = np.array([sel.mean[r] for r in orders])
    std = np.array([sel.std[r] for r in orders])
    exact = np.array([sel.exact[r] for r in orders])
    colors = ["tab:orange" if r in sel.orders else "tab:blue" for r in orders]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.bar([str(r) for r in orders], mean, yerr=std, color=colors, capsize=3, label="Nyström mean ± std")
    ax.plot([str(r) for r in orders], exact, "k_", markersize=18, label="exact (c = l)")
    lo = float(min(mean.min() - std.max(), exact.min()))
    hi = float(max((mean + std).max(), exact.max()))
    pad = 0.1 * (hi - lo) if hi > lo else 0.1 * abs(hi) + 1e-12
    ax.set_ylim(max(0.0, lo - pad), hi + pad)
    ax.set_xlabel("additive-kernel order")
    ax.set_ylabel("C_ree (lower is better)")
    ax.set_title(f"{title}: chosen {', '.join(map(str, sel.orders))}\n"
                 f"T={sel.trials}, c={sel.columns}, k={sel.rank}, mu={sel.mu:g}", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    try:
        fig.savefig(path, dpi=120)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot write plot {path}: {exc}") from None
    finally:
        plt.close(fig)
    return path
