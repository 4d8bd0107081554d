"""Vehicle models a truth plant and an estimator may both build on (neither owns them)."""
