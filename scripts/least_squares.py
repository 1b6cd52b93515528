"""Least-squares slope, shared by the study and plotting scripts (funnel scale and discharge,
validation convergence)."""
import math


def slope(xs, ys):
    """Least-squares slope of ys against xs."""
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def log_log_slope(xs, ys):
    """Least-squares slope of log y against log x: an order of convergence or a scaling law."""
    return slope([math.log(x) for x in xs], [math.log(y) for y in ys])
