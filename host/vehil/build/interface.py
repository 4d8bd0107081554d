"""Does each estimator's C agree with its Python spec? Checked at build time on the native
board, the estimators' own C compiled for the host.

The spec (vehil/estimators/NAME.py) is the interface's one statement: the C descriptor
must report the spec's C id, name, modes and counts, and its parameter checks must take
exactly the spec's ranges in the spec's formats. The ranges are probed through CONFIG, the
path a run takes: with every other parameter at its default, each parameter at its lo and
hi must be accepted and just outside them refused, naming that parameter, in every mode
the spec lists. A Q format that differs shows as a refusal at lo or hi or an acceptance
outside (the C reads another value than the spec encoded).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from vehil.errors import BoardError
from vehil.estimators import EstimatorSpec
from vehil.link import EstimatorInfo, Link
from vehil.protocol.schema import SCHEMA
from vehil.spec import INT32_RANGE, Param

# Outside a range by this much relative to the bound (float32 resolves 6e-8), or by at
# least two LSBs of the parameter's Q format.
_OUTSIDE = 1e-5


def _encode(spec: EstimatorSpec, values: Mapping[str, float], i: int, code: int | None) -> bytes:
    """The spec's encoding of `values`, with parameter i's FIXED code given directly."""
    body = bytearray(spec.encode_params(values, "FIXED" if code is not None else "F32"))
    if code is not None:
        body[4 * i : 4 * i + 4] = int(code).to_bytes(4, "little", signed=True)
    return bytes(body)


def _probes(p: Param, mode: str) -> list[tuple[str, float, int | None, bool]]:
    """(what, value, FIXED code or None, accepted) for parameter p's range in `mode`."""
    out: list[tuple[str, float, int | None, bool]] = []
    for bound, side in ((p.lo, -1), (p.hi, 1)):
        if not math.isfinite(bound):
            continue
        name = "lo" if side < 0 else "hi"
        past = bound + side * max(abs(bound) * _OUTSIDE, 2 * p.lsb if mode == "FIXED" else 0.0)
        if mode == "F32":
            past32 = float(np.float32(past))
            if past32 == float(np.float32(bound)):
                past32 = float(np.nextafter(np.float32(bound), np.float32(side * math.inf)))
            out += [(name, bound, None, True), (f"past {name}", past32, None, False)]
        else:
            scaled = bound * 2.0**p.q
            inside = math.ceil(scaled) if side < 0 else math.floor(scaled)
            beyond = round(past * 2.0**p.q)
            out.append((name, bound, inside, True))
            if INT32_RANGE[0] <= beyond <= INT32_RANGE[1]:
                out.append((f"past {name}", past, beyond, False))
    return out


def _fits_q(spec: EstimatorSpec, p: Param) -> str | None:
    lo, hi = p.fixed_range
    if (math.isfinite(p.lo) and p.lo < lo) or (math.isfinite(p.hi) and p.hi > hi):
        return (
            f"{spec.name}.params.{p.name}: range [{p.lo:g}, {p.hi:g}] does not fit its Q format "
            f"q={p.q} (int32 holds [{lo:g}, {hi:g}]): lower q"
        )
    return None


def _check_ranges(link: Link, spec: EstimatorSpec, board: EstimatorInfo) -> list[str]:
    problems: list[str] = []
    defaults = spec.param_values({})
    for mode in spec.modes:
        try:
            link.config(board.id, SCHEMA.mode[mode], spec.encode_params(defaults, mode))
        except BoardError as exc:
            return [f"{spec.name} ({mode}): the C refuses the spec's defaults: {exc}"]
        for i, p in enumerate(spec.params):
            if mode == "FIXED" and (bad := _fits_q(spec, p)):
                problems.append(bad)
                continue
            for what, value, code, in_range in _probes(p, mode):
                values = {**defaults, p.name: value}
                rules = spec.rule_problems(values, mode)
                accepted = in_range and not rules
                body = _encode(spec, values, i, code)
                try:
                    link.config(board.id, SCHEMA.mode[mode], body)
                    refused = None
                except BoardError as exc:
                    if exc.code != "BAD_PARAM":
                        raise
                    refused = exc.detail
                field = f"{spec.name}.params.{p.name} ({mode}, q={p.q})"
                if accepted and refused is not None:
                    other = spec.params[refused].name if refused < len(spec.params) else refused
                    problems.append(
                        f"{field}: the spec's {what} {value:g} is refused by the C (parameter "
                        f"{other}): the C's range or Q format differs from [{p.lo:g}, {p.hi:g}]"
                        ", or the C has a rule the spec's `rules` lack"
                    )
                elif rules and in_range and refused is None:
                    problems.append(
                        f"{field}: {value:g} is accepted by the C, but the spec's rules refuse "
                        f"it ({'; '.join(rules)})"
                    )
                elif not in_range and refused != i:
                    problems.append(
                        f"{field}: {value:g}, {what} {p.lo if 'lo' in what else p.hi:g}, is "
                        f"{'accepted' if refused is None else f'refused as parameter {refused}'}"
                        f" by the C: its range or Q format is wider than [{p.lo:g}, {p.hi:g}]"
                    )
    return problems


def _check_descriptor(spec: EstimatorSpec, board: EstimatorInfo) -> list[str]:
    problems = []
    any_length = board.n_inputs == 0 and board.n_outputs == 0
    wanted = {
        "name": (spec.name, board.name),
        "modes": (tuple(sorted(spec.modes)), tuple(sorted(board.modes))),
        "n_params": (len(spec.params), board.n_params),
    }
    if not any_length:
        wanted["n_inputs"] = (len(spec.inputs), board.n_inputs)
        wanted["n_outputs"] = (len(spec.outputs), board.n_outputs)
    for field, (want, got) in wanted.items():
        if want != got:
            problems.append(
                f"{spec.name}: the C descriptor (id {board.id}) has {field} = {got}, "
                f"the spec {want}"
            )
    return problems


def check(link: Link, specs: Iterable[EstimatorSpec], *, every_spec_built: bool) -> list[str]:
    """Every disagreement between the board's estimators and the specs, each naming its
    field; [] if they agree. `every_spec_built`: a spec with no estimator on the board
    is a problem too (the native board builds them all)."""
    assert link.info is not None
    by_id = {e.id: e for e in link.info.estimators}
    problems: list[str] = []
    seen: set[int] = set()
    for spec in specs:
        board = by_id.get(spec.c_id)
        if board is None:
            if every_spec_built:
                problems.append(f"{spec.name}: the spec's C id {spec.c_id} is not on the board")
            continue
        seen.add(spec.c_id)
        mismatch = _check_descriptor(spec, board)
        problems += mismatch or _check_ranges(link, spec, board)
    problems += [
        f"{e.name}: the board has it (C id {e.id}) but no spec names that id"
        for e in link.info.estimators
        if e.id not in seen
    ]
    return problems
