"""Seed 000's braking car as data, for the plant that simulates it and the filter that models it.

Table 2's car (the Pride) is the default of every parameter, so a scenario runs
another car by naming its values, in the plant (the truth) and in the estimator
(its model) separately. W = m g (Table 2's 8330 N is 850 kg × 9.8). Burckhardt's
surface coefficients c1-c3 are his published values (dry asphalt by default): the
paper gives none.
"""

from __future__ import annotations

from dataclasses import dataclass

from vehil.spec import Param, ParamRecord

CAR_PARAMS = (
    Param("m", "kg", q=0, default=850.0, lo=100.0, hi=5000.0, doc="vehicle mass"),
    Param("r_w", "m", q=0, default=0.27, lo=0.1, hi=1.0, doc="wheel radius"),
    Param("i_w", "kg*m^2", q=0, default=4.15, lo=0.05, hi=50.0, doc="wheel inertia"),
    Param("k_b", "1", q=0, default=0.7, lo=0.0, hi=1.0, doc="front share of the brake torque"),
    Param("psi", "1", q=0, default=0.85, lo=0.1, hi=1.5, doc="friction scale ψ of eqs. 7-8"),
    Param("h_cg", "m", q=0, default=0.57, lo=0.1, hi=2.0, doc="centre of gravity height"),
    Param("l_f", "m", q=0, default=0.92, lo=0.3, hi=4.0, doc="front axle to CG"),
    Param("l_r", "m", q=0, default=1.425, lo=0.3, hi=4.0, doc="rear axle to CG"),
    Param("i_z", "kg*m^2", q=0, default=1627.0, lo=50.0, hi=20_000.0, doc="yaw inertia"),
    Param("rho", "kg/m^3", q=0, default=1.027, lo=0.5, hi=1.5, doc="air density"),
    Param("c_d", "1", q=0, default=0.32, lo=0.0, hi=2.0, doc="drag coefficient"),
    Param("a_f", "m^2", q=0, default=1.87, lo=0.5, hi=10.0, doc="frontal area"),
    Param("h_a", "m", q=0, default=1.16, lo=0.0, hi=3.0, doc="height of the drag force"),
    Param("g", "m/s^2", q=0, default=9.81, lo=9.0, hi=10.5, doc="gravity"),
)

# Burckhardt (c1, c2, c3) by surface.
SURFACES = {
    0: ("dry asphalt", 1.2801, 23.99, 0.52),
    1: ("wet asphalt", 0.857, 33.822, 0.347),
    2: ("dry concrete", 1.1973, 25.168, 0.5373),
    3: ("dry cobblestone", 1.3713, 6.4565, 0.6691),
    4: ("wet cobblestone", 0.4004, 33.708, 0.1204),
    5: ("snow", 0.1946, 94.129, 0.0646),
    6: ("ice", 0.05, 306.39, 0.0),
}
SURFACE_DOC = ", ".join(f"{k} {v[0]}" for k, v in SURFACES.items())


@dataclass(frozen=True)
class Car(ParamRecord):
    """The values of CAR_PARAMS, by name."""

    m: float
    r_w: float
    i_w: float
    k_b: float
    psi: float
    h_cg: float
    l_f: float
    l_r: float
    i_z: float
    rho: float
    c_d: float
    a_f: float
    h_a: float
    g: float

    @property
    def wheelbase(self) -> float:
        return self.l_f + self.l_r

    @property
    def weight(self) -> float:
        return self.m * self.g
