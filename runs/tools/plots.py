"""What the studies' charts under runs/ share: pyplot without a display, one colour per time scheme,
a panel's labels and style, an energy-drift curve, and saving a figure. Import with sys.path
pointing at runs/tools."""

# one colour per time scheme (and TS alpha2 variant), the same in every study's charts
SCHEME_COLORS = {"implicit_euler": "k", "bdf2": "tab:blue", "implicit_midpoint": "tab:red", "newmark": "tab:orange",
                 "discrete_gradient": "tab:green", "ts alpha2": "tab:purple", "ts alpha2 r=1": "tab:purple",
                 "ts alpha2 r=0.5": "tab:pink"}


def pyplot():
    """matplotlib.pyplot on the Agg backend (the studies run headless)"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def style(ax, xlabel, ylabel, title, title_size=None, xlog=False, ylog=False, grid=True, legend=None):
    """one panel's scales, labels, title, grid and legend (legend: ax.legend's keywords, None for none)"""
    if xlog:
        ax.set_xscale("log")
    if ylog:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, **({} if title_size is None else {"fontsize": title_size}))
    if grid:
        ax.grid(True, alpha=0.3)
    if legend is not None:
        ax.legend(**legend)


def energy_drift(ax, rows, **kw):
    """E(t) - E(0) of one run's rows (columns t and total, in time order)"""
    e0 = float(rows[0]["total"])
    return ax.plot([float(r["t"]) for r in rows], [float(r["total"]) - e0 for r in rows], **kw)


def save(fig, path, dpi=90):
    """a figure laid out tight, written to path"""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
