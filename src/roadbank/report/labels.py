"""Display names of the estimators, as the paper names its methods, plus ours, and the tuning
each one runs with (one name, one filter and tuning, in every command, table and figure)."""

LABELS = {
    "pif-paper": "PIF, Table 4",
    "pif-modified": "PIF, default tuning",
    "pio-original": "PIO",
    "dfc": "DFC",
    "uio": "UIO",
    "pio-modified": "PIO (modified model)",
    "pif-original": "PIF (original model), Table 4",
    "kalman": "Kalman (ours)",
    "pif-rate": "PIF + bank rate (ours)",
    "pif-adaptive": "PIF + friction-usage schedule (ours)",
    "pif-rate-adaptive": "PIF + bank rate + friction schedule (ours)",
    "pif-gated": "PIF switched to a fast bank-rate PIF on yaw acceleration (ours)",
    "pif-smoother": "PIF smoother, offline (ours)",
    "kinematic-smoother": "Kinematic, low-passed forward and backward, offline (ours)",
    "kinematic": "Kinematic",
    "kinematic-lp": "Kinematic, low-passed (ours)",
    "kinematic-ff": "Kinematic, low-passed + centripetal feed-forward (ours)",
    "kinematic-pif": "Kinematic-ff, switched to the PIF on yaw acceleration (ours; the default)",
}

#: the estimators whose weights are the paper's Table 4 (SI reading); every other name runs
#: roadbank's default (``estimators.make(name)``, docs/estimators.md)
TABLE4 = ("pif-paper", "pif-original")

#: the methods the paper plots in its scenario figures, and ours
PAPER_SET = ("pif-paper", "pio-original", "dfc", "uio", "kalman", "pif-modified")

CONDITION_LABELS = {
    "nominal": "mu = 0.85",
    "low-mu": "mu = 0.3",
    "misaligned": "ay = ay_real cos(10 deg)",
    "cf120": "Cf = 1.2 Cf_ss",
    "cf50": "Cf = 0.5 Cf_ss",
    "cf150": "Cf = 1.5 Cf_ss",
}


def label(name: str) -> str:
    """Display name of an estimator."""
    return LABELS.get(name, name)


def tuning_of(name: str) -> str:
    """Which weights the estimator ``name`` runs with: ``"Table 4"`` or ``"default"``."""
    return "Table 4" if name in TABLE4 else "default"


def tuning_legend(names) -> str:
    """One line saying which tuning each of the estimators ``names`` runs with (markdown)."""
    paper = [n for n in names if n in TABLE4]
    default = "every column" if not paper else "every other column"
    text = "Tuning: "
    if paper:
        text += ", ".join(f"`{n}`" for n in paper) + ": the paper's Table 4 weights (SI reading); "
    return text + (f"{default}: roadbank's default tuning (`estimators.make(name)`: the filter and tuning "
                   "`roadbank estimate -e name` runs, which also sets the default-tuned PIFs' noise "
                   "weights from the log).")
