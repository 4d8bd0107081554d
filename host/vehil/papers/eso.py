"""Seed 003 (ESO vs KF-UI on a quarter car, active suspension): the paper's orderings.

The paper prints no result numbers, only orderings in its text (Section 6), so `vehil reproduce eso`
puts our figure beside each claim and marks it holds / fails, twice: on the shipped
drives' car (Table 1 with +15 % m_s, +10 % k1, -10 % c1 and 75 N of smooth friction) and
on a higher-fidelity car (HIFI: Dahl friction, stops, tire damping, progressive tire,
enveloping, other wheel and tire, accelerometers with a scale error and 30 Hz bandwidth).
Estimation errors are RMS against the truth passed through the conditioning's band
(nothing below its 0.5 Hz high-pass, Section 6.1, survives the chain), after a 5 s
settling time. The closed loops (S5, S6) run the float64 ECU against the plant here, and
S5 again with the C on a board through the scenario runner (native unless --board names
another).

Then the road estimate on three passive drives of a car the observer does not know
(scenarios/eso/mismatch-*: +15 % m_s, -8 % k1, 60 N friction), in band, against the
all-zero estimate, band-pass + double integration (BP+DI) and the KF-UI, at 100 Hz and
1 kHz, the paper's ESO beside the retuned one (docs/estimators/eso.md).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from rich.console import Console
from rich.table import Table

from vehil import plants, scenario
from vehil.eso_response import bpdi
from vehil.estimators import eso, kfui
from vehil.estimators._accel_conditioning import Channel, band_limit
from vehil.estimators.eso import Ecu, NoUpdate
from vehil.plants.quarter_car import QuarterCarLoop

KEY = "eso"
TITLE = "ESO and KF-UI on a quarter car, active suspension (seed 003)"
SETTLE_S = 5.0
STATES = ("x_s", "v_s", "x_us", "v_us", "x_r")
COLUMNS = (0, 1, 2, 3, 6)  # of the ECU's outputs
EPS_THREE = (0.05, 0.1, 0.5)  # S1: the paper's 0.1 and two of ours, around it
EPS_SWEEP = (0.02, 0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3, 0.5)
SUSP_LIMIT = 0.08  # m
# m: the paper prints 0.17, no unit; 0.17 m would be ~10x the static load, so we read the
# no-lift-off bound, the static deflection (m_s + m_us) g / k_us.
TIRE_LIMIT = 0.018
U_MAX = 1500.0  # N


@dataclass
class LoopFigures:
    """Comfort and limits of one closed-loop run: body acceleration, deflections, u."""

    rms_a_body: float
    max_defl: float
    max_tire: float
    max_u: float
    saturated: float  # fraction of samples with |u*| > u_max

    def within_limits(self) -> bool:
        return (
            self.max_defl <= SUSP_LIMIT
            and self.max_tire <= TIRE_LIMIT
            and self.max_u <= U_MAX
            and self.saturated <= 0.01
        )


# The higher-fidelity car the claims are checked on again (plants/quarter_car_truth.py).
HIFI: dict[str, float] = {
    "friction_k": 1e5,
    "c_tire": 150.0,
    "tire_prog": 10.0,
    "patch_len": 0.15,
    "lift_off": 1,
    "stop_gap": 0.07,
    "mus_scale": 1.1,
    "kus_scale": 0.9,
    "knl_scale": 1.2,
    "c2_scale": 0.8,
    "acc_scale": 1.02,
    "acc_bw": 30.0,
}
PLANTS: dict[str, dict[str, float]] = {"shipped car": {}, "hi-fi car": HIFI}


def _drive(
    name: str, over: Mapping[str, float] | None = None, T: float | None = None
) -> tuple[scenario.Scenario, plants.Trace]:
    sc = scenario.load(name)
    T = T or sc.sample_time
    pp = {**sc.plant_params, **(over or {})}
    trace = plants.get("quarter_car").run(pp, sc.duration, T, sc.seed)
    return sc, trace


def state_errors(
    ecu: Ecu | Callable[[np.ndarray], np.ndarray], trace: plants.Trace, p: Mapping[str, float]
) -> dict[str, float]:
    """RMS error of x̂_s, ẋ̂_s, x̂_us, ẋ̂_us and x̂_r against the in-band truth (of an ECU,
    or of a step function with the ECU's output layout)."""
    step = ecu.step if isinstance(ecu, Ecu) else ecu
    u = np.column_stack([trace.signals["a_s"], trace.signals["a_us"]])
    est = np.array([step(row) for row in u])
    k0 = int(SETTLE_S / p["T"])
    out = {}
    for name, col in zip(STATES, COLUMNS, strict=True):
        truth = band_limit(trace.truth[name], p["T"], p["f_hp"], p["f_lp"], p["f_post"])
        out[name] = float(np.sqrt(np.mean((est[k0:, col] - truth[k0:]) ** 2)))
    return out


def _normalised(errors: Mapping[str, float], trace: plants.Trace) -> float:
    """The 4 state errors, each over its truth's RMS, RMS-combined (one number for S1)."""
    ratios = [errors[n] / np.std(trace.truth[n]) for n in STATES[:4]]
    return float(np.sqrt(np.mean(np.square(ratios))))


def eps_sweep(over: Mapping[str, float] | None = None) -> dict[float, tuple[float, float]]:
    """S1: ε -> (normalised 4-state error, RMS step-to-step jitter of ẋ̂_s (m/s))."""
    sc, trace = _drive("s1-sine-eso", over)
    out = {}
    for e in sorted({*EPS_SWEEP, *EPS_THREE}):
        p = sc.params | {"eps": e}
        ecu = eso.ecu(p)
        errors = state_errors(ecu, trace, p)
        ecu2 = eso.ecu(p)
        u = np.column_stack([trace.signals["a_s"], trace.signals["a_us"]])
        v = np.array([ecu2.step(row)[1] for row in u])[int(SETTLE_S / p["T"]) :]
        jitter = float(np.sqrt(np.mean(np.diff(v, 2) ** 2)))
        out[e] = (_normalised(errors, trace), jitter)
    return out


def integration_check(over: Mapping[str, float] | None = None) -> dict[str, float]:
    """S2: x_s by double integration, unfiltered vs band-passed, against the truth."""
    sc, trace = _drive("s1-sine-eso", over)
    p = sc.params
    raw = Channel(p["T"], p["f_hp"], p["f_lp"], 0.0, filtered=False)
    filt = Channel(p["T"], p["f_hp"], p["f_lp"], p["f_post"])
    a = trace.signals["a_s"]
    x_raw = np.array([raw.step(float(v))[2] for v in a])
    x_f = np.array([filt.step(float(v))[2] for v in a])
    k0 = int(SETTLE_S / p["T"])
    truth = band_limit(trace.truth["x_s"], p["T"], p["f_hp"], p["f_lp"], p["f_post"])
    return {
        "unfiltered |x| at the end (m)": float(abs(x_raw[-1])),
        "unfiltered drift, last / first half max": float(
            np.abs(x_raw[len(a) // 2 :]).max() / max(np.abs(x_raw[: len(a) // 2]).max(), 1e-12)
        ),
        "band-passed RMS error (m)": float(np.sqrt(np.mean((x_f[k0:] - truth[k0:]) ** 2))),
        "band-passed correlation with the in-band truth": float(
            np.corrcoef(x_f[k0:], truth[k0:])[0, 1]
        ),
        "true x_s RMS (m)": float(np.std(trace.truth["x_s"])),
    }


def observer_errors(over: Mapping[str, float] | None = None) -> dict[str, dict[str, float]]:
    """S3 and S4 on the pseudo-random road: ESO B, the no-updating baseline, ESO A, KF-UI."""
    sc, trace = _drive("s3-random-eso-b", over)
    p_eso = sc.params
    p_kf = kfui.SPEC.param_values({"active": 0})
    return {
        "ESO B (updating)": state_errors(eso.ecu(p_eso), trace, p_eso),
        "no updating": state_errors(Ecu(p_eso, NoUpdate(p_eso)), trace, p_eso),
        "ESO A": state_errors(eso.ecu(p_eso | {"variant": 0}), trace, p_eso),
        "KF-UI (Euler)": state_errors(kfui.ecu(p_kf), trace, p_kf),
    }


def loop_figures(truth: Mapping[str, np.ndarray], u_raw: np.ndarray) -> LoopFigures:
    return LoopFigures(
        rms_a_body=float(np.sqrt(np.mean(truth["a_body"] ** 2))),
        max_defl=float(np.abs(truth["defl"]).max()),
        max_tire=float(np.abs(truth["tire_defl"]).max()),
        max_u=float(np.abs(truth["u_applied"]).max()),
        saturated=float(np.mean(np.abs(u_raw) > U_MAX)),
    )


def closed_loop(name: str, over: Mapping[str, float] | None = None) -> LoopFigures:
    """A closed-loop scenario with the float64 ECU in the loop (no board)."""
    sc = scenario.load(name)
    plant = QuarterCarLoop(
        plants.get("quarter_car").param_values({**sc.plant_params, **(over or {})}),
        sc.sample_time,
        sc.seed,
    )
    ecu = sc.estimator.reference(sc.params)
    rows: dict[str, list[float]] = {"a_body": [], "defl": [], "tire_defl": [], "u_applied": []}
    u_raw = []
    for _ in range(sc.samples):
        _, signals, truth = plant.measure()
        out = ecu.step(np.array([signals["a_s"], signals["a_us"]]))
        u_raw.append(ecu.u_raw)  # type: ignore[attr-defined]
        plant.apply({"u": float(out[7])})
        for k in rows:
            rows[k].append(truth[k])
    return loop_figures({k: np.array(v) for k, v in rows.items()}, np.array(u_raw))


def board_loop(name: str, board: str) -> tuple[LoopFigures, float]:
    """A closed-loop scenario through the runner with the C on `board`: its figures and the
    median cycles per step."""
    from vehil import runner

    run = runner.run(scenario.load(name), board, console=Console(quiet=True))
    if run.error:
        raise RuntimeError(f"{name} on {board}: {run.error}")
    truth = run.prepared.trace.truth
    # The board saturates u itself; its unsaturated u* is not on the wire: flag |u| at the limit.
    u = run.board_out[:, 7]
    figs = loop_figures(truth, np.where(np.abs(u) >= U_MAX * (1 - 1e-6), 2 * U_MAX, u))
    return figs, float(np.median(run.cycles))


def _mark(ok: bool) -> str:
    return "[green]holds[/]" if ok else "[red]fails[/]"


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def claims(
    console: Console, car: str, over: Mapping[str, float], board: str | None
) -> list[tuple[str, str, bool]]:
    """The paper's orderings on one car: (claim, our figures, holds)."""
    checks: list[tuple[str, str, bool]] = []

    sweep = eps_sweep(over)
    t = Table(title=f"S1 (test 1, sine 10 mm at 1.5 Hz), {car}: ESO A over ε")
    for col in ("ε", "normalised 4-state RMS error", "ẋ̂_s jitter (m/s)"):
        t.add_column(col, justify="right")
    for eps_value, (err, jit) in sweep.items():
        t.add_row(f"{eps_value:g}" + (" *" if eps_value in EPS_THREE else ""), _fmt(err), _fmt(jit))
    console.print(t)
    three = {e: sweep[e] for e in EPS_THREE}
    best = min(three, key=lambda e: three[e][0])
    best_all = min(sweep, key=lambda e: sweep[e][0])
    checks.append(
        (
            "S1: ε = 0.1 no worse than ε = 0.5",
            f"{_fmt(three[0.1][0])} vs {_fmt(three[0.5][0])}",
            three[0.1][0] <= three[0.5][0],
        )
    )
    checks.append(
        (
            "S1: smaller ε noisier (jitter 0.05 > 0.1)",
            f"{_fmt(three[0.05][1])} vs {_fmt(three[0.1][1])}",
            three[0.05][1] > three[0.1][1],
        )
    )
    checks.append(
        (
            "S1: ε = 0.1 best of (0.05, 0.1, 0.5)",
            f"best of three {best:g}, of the sweep {best_all:g}",
            best == 0.1,
        )
    )

    s2 = integration_check(over)
    checks.append(
        (
            "S2: unfiltered double integration drifts",
            f"|x| at the end {_fmt(s2['unfiltered |x| at the end (m)'])} m "
            f"(true RMS {_fmt(s2['true x_s RMS (m)'])} m)",
            s2["unfiltered |x| at the end (m)"] > 10 * s2["true x_s RMS (m)"],
        )
    )
    corr = s2["band-passed correlation with the in-band truth"]
    checks.append(("S2: band-passed tracks the truth (corr > 0.9)", f"corr {corr:.3f}", corr > 0.9))

    errs = observer_errors(over)
    t = Table(title=f"S3/S4 (test 2, pseudo-random road), {car}: RMS errors, in band")
    t.add_column("observer")
    for n in STATES:
        t.add_column(n + (" (m)" if n[0] == "x" else " (m/s)"), justify="right")
    for name, row in errs.items():
        t.add_row(name, *(_fmt(row[n]) for n in STATES))
    console.print(t)
    upd, noupd, kf = errs["ESO B (updating)"], errs["no updating"], errs["KF-UI (Euler)"]
    for n in STATES:
        checks.append(
            (
                f"S3: {n} with updating < without",
                f"{_fmt(upd[n])} vs {_fmt(noupd[n])}",
                upd[n] < noupd[n],
            )
        )
    for n in STATES:
        checks.append((f"S4: {n} ESO < KF-UI", f"{_fmt(upd[n])} vs {_fmt(kf[n])}", upd[n] < kf[n]))

    loops = {
        "passive": closed_loop("s5-iso-passive", over),
        "active, ESO": closed_loop("s5-iso-active-eso", over),
        "active, KF-UI": closed_loop("s6-iso-active-kfui", over),
    }
    on_board: LoopFigures | None = None
    if board is not None:
        on_board, cycles = board_loop("s5-iso-active-eso", board)
        loops[f"active, ESO on {board} (F32)"] = on_board
    t = Table(title=f"S5/S6 (ISO 8608 class C at 60 km/h, 20 s, closed loop), {car}")
    for col in (
        "run",
        "RMS a_body (m/s²)",
        "max |Δx| (m)",
        "max tire defl. (m)",
        "max |u| (N)",
        "saturated",
    ):
        t.add_column(col, justify="right" if col != "run" else "left")
    for name, f in loops.items():
        t.add_row(
            name,
            _fmt(f.rms_a_body),
            _fmt(f.max_defl),
            _fmt(f.max_tire),
            f"{f.max_u:.0f}",
            f"{f.saturated:.1%}",
        )
    console.print(t)
    pas, act, akf = loops["passive"], loops["active, ESO"], loops["active, KF-UI"]
    checks += [
        (
            "S5: RMS a_body active (ESO) < passive",
            f"{_fmt(act.rms_a_body)} vs {_fmt(pas.rms_a_body)}",
            act.rms_a_body < pas.rms_a_body,
        ),
        (
            "S5: active keeps |Δx| <= 0.08, tire <= 0.018, |u| <= 1500, no saturation",
            f"{_fmt(act.max_defl)}, {_fmt(act.max_tire)}, {act.max_u:.0f}, {act.saturated:.1%}",
            act.within_limits(),
        ),
        (
            "S5: passive exceeds the suspension and tire limits",
            f"{_fmt(pas.max_defl)}, {_fmt(pas.max_tire)}",
            pas.max_defl > SUSP_LIMIT and pas.max_tire > TIRE_LIMIT,
        ),
        (
            "S6: both active variants keep the limits",
            f"KF-UI {_fmt(akf.max_defl)}, {_fmt(akf.max_tire)}, {akf.max_u:.0f}",
            act.within_limits() and akf.within_limits(),
        ),
        (
            "S6: RMS a_body with the ESO < with the KF-UI",
            f"{_fmt(act.rms_a_body)} vs {_fmt(akf.rms_a_body)}",
            act.rms_a_body < akf.rms_a_body,
        ),
    ]

    if on_board is not None:
        checks.append(
            (
                "S5: the board's loop (C) also beats passive",
                f"{_fmt(on_board.rms_a_body)} ({cycles:,.0f} cycles/step median)",
                on_board.rms_a_body < pas.rms_a_body,
            )
        )
    return checks


def reproduce(console: Console, board: str | None = None) -> int:
    per_car = {
        car: claims(console, car, over, (board or "native") if not over else None)
        for car, over in PLANTS.items()
    }
    t = Table(title=f"{TITLE}: the paper's orderings (it prints no numbers)")
    t.add_column("claim")
    for car in per_car:
        t.add_column(f"ours, {car}")
        t.add_column("verdict")
    rows = {claim: [] for claim, _, _ in per_car["shipped car"]}  # type: dict[str, list[str]]
    for checks in per_car.values():
        found = {claim: (ours, ok) for claim, ours, ok in checks}
        for claim, cells in rows.items():
            ours, ok = found.get(claim, ("-", None))
            cells += [ours, "n/a" if ok is None else _mark(ok)]
    for claim, cells in rows.items():
        t.add_row(claim, *cells)
    console.print(t)
    for car, checks in per_car.items():
        held = sum(ok for _, _, ok in checks)
        console.print(f"{car}: {held} of {len(checks)} orderings hold")
    road_table(console)
    return 0 if all(ok for checks in per_car.values() for _, _, ok in checks) else 1


# The drives (scenario, plant parameters over it). The ISO road's short waves reach the
# wheel's accelerometer above 50 Hz and alias into the band at 100 Hz; a 30 Hz sensor
# bandwidth and a 0.15 m contact patch (what a real tire and sensor do) take them out.
MISMATCH: dict[str, tuple[str, dict[str, float]]] = {
    "ISO C, 60 km/h": ("mismatch-iso-c60-eso", {}),
    "ISO C, anti-aliased": ("mismatch-iso-c60-eso", {"acc_bw": 30.0, "patch_len": 0.15}),
    "bumps, 30 km/h": ("mismatch-bumps30-eso", {}),
    "chirp 0.5-15 Hz": ("mismatch-chirp-eso", {}),
}
# The retuned ESO (docs/estimators/eso.md): the Euler loop's poles at e^{-T/ε}, the road
# from the body's acceleration; at 1 kHz ε = 3 ms, the smallest whose gains fit FIXED.
RETUNED = {
    0.01: {"design": 1, "eps": 0.1, "road_from": 1},
    0.001: {"design": 1, "eps": 0.003, "road_from": 1},
}


def _zero(u: np.ndarray) -> np.ndarray:
    return np.zeros(8)


def road_errors(T: float) -> dict[str, dict[str, float]]:
    """Estimator -> drive -> in-band RMS error of x̂_r (m), on the mismatched drives at T."""
    out: dict[str, dict[str, float]] = {}
    for drive, (name, over) in MISMATCH.items():
        sc, trace = _drive(name, over, T)
        p = eso.SPEC.param_values({"active": 0, "T": T})
        p_kf = kfui.SPEC.param_values({"active": 0, "T": T})
        runs: dict[str, tuple[Ecu | Callable[[np.ndarray], np.ndarray], Mapping[str, float]]] = {
            "all-zero": (_zero, p),
            "BP+DI (the conditioning alone)": (bpdi(p), p),
            "KF-UI (paper's Q, R)": (kfui.ecu(p_kf), p_kf),
            "ESO, paper (A, ε = 0.1)": (eso.ecu(p), p),
        }
        tuned = p | RETUNED[T]
        label = f"ESO retuned (design 1, ε = {tuned['eps']:g}, road from the body)"
        runs[label] = (eso.ecu(tuned), tuned)
        for est, (make, params) in runs.items():
            out.setdefault(est, {})[drive] = state_errors(make, trace, params)["x_r"]
    return out


def road_table(console: Console) -> None:
    for T in RETUNED:
        errs = road_errors(T)
        t = Table(
            title=f"Road estimate on a car the observer does not know (+15 % m_s, -8 % k1, "
            f"60 N friction), passive, {1 / T:.0f} Hz: in-band RMS error of x̂_r (mm)"
        )
        t.add_column("estimator")
        for drive in MISMATCH:
            t.add_column(drive, justify="right")
        zero = errs["all-zero"]
        for est, row in errs.items():
            worse = [est != "all-zero" and row[d] >= zero[d] for d in MISMATCH]
            t.add_row(
                est,
                *(f"{1e3 * row[d]:.2f}{' ✗' * w}" for d, w in zip(MISMATCH, worse, strict=True)),
            )
        console.print(t)
    console.print("✗: no better than the all-zero estimate")
