"""Display names of the estimators, as the paper names its methods, plus ours."""

LABELS = {
    "pif-modified": "PIF",
    "pif-default": "PIF (roadbank default)",
    "pio-original": "PIO",
    "dfc": "DFC",
    "uio": "UIO",
    "pio-modified": "PIO (modified model)",
    "pif-original": "PIF (original model)",
    "kalman": "Kalman (ours)",
    "pif-rate": "PIF + bank rate (ours)",
    "pif-adaptive": "PIF + friction-usage schedule (ours)",
    "pif-rate-adaptive": "PIF + bank rate + friction schedule (ours)",
    "pif-gated": "PIF switched to a fast bank-rate PIF on yaw acceleration (ours)",
    "pif-smoother": "PIF smoother, offline (ours)",
    "kinematic": "Kinematic",
}

#: the methods the paper plots in its scenario figures, and ours
PAPER_SET = ("pif-modified", "pio-original", "dfc", "uio", "kalman", "pif-default")

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
