"""Cycle-exact profiles by function on simavr (`vehil profile --functions`): the bridge
counts every instruction's cycles in a shadow call stack (sim/profiler.c); this package
names them from the ELF and reports them."""

from vehil.fnprofile.model import FunctionStats, Profile, ProfileError

__all__ = ["FunctionStats", "Profile", "ProfileError"]
