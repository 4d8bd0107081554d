"""vehil: microcontroller-in-the-loop test harness for vehicle state estimators."""

__version__ = "0.1.0"
