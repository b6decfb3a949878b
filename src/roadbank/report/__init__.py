"""Reporting: the paper-reproduction study, its tables, figures, claims and report."""
