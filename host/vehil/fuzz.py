"""Coverage-guided fuzzing of the firmware's message core: `python -m vehil.fuzz --seconds N`.

Builds fuzz/fuzz_dispatch.c with the native board's sources under clang's libFuzzer,
AddressSanitizer and UndefinedBehaviorSanitizer, seeds it with valid frames made from
the schema (every request, a CONFIG and SAMPLEs for every estimator and mode), runs
it, and prints executions, coverage and crashes (a crash leaves its input in
build/fuzz/). Needs Debian's clang and libclang-rt-14-dev.
"""

from __future__ import annotations

import argparse
import random
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from vehil import estimators, project
from vehil.build import native, project_image, registry
from vehil.build.objects import Unit, compile_units, link
from vehil.errors import BuildError
from vehil.link import config_requests
from vehil.paths import BUILD_DIR, DATA_ROOT
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA

FUZZ_DIR = BUILD_DIR / "fuzz"
HARNESS = DATA_ROOT / "fuzz" / "fuzz_dispatch.c"


@dataclass(frozen=True)
class FuzzResult:
    executions: int
    coverage: int
    features: int
    crashes: list[Path]
    seconds: float


def clang() -> str | None:
    return shutil.which("clang") or shutil.which("clang-14")


def build() -> Path:
    cc = clang()
    if cc is None:
        raise BuildError("clang is not installed: `apt-get install clang libclang-rt-14-dev`")
    cxx = shutil.which("clang++") or cc.replace("clang", "clang++")
    FUZZ_DIR.mkdir(parents=True, exist_ok=True)
    sanitizers = ["-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all"]
    # Every estimator, or a project's image's set with its C (vehil.toml)
    here = project.current()
    chosen, c_sources = (project_image(here), here.c_sources) if here else ("all", ())
    gen = registry.write(FUZZ_DIR / "gen", registry.select(chosen, c_sources), c_sources).parent
    todo = [
        # clang warns about more than gcc: its warnings do not stop the fuzzer
        Unit(u.source, (*(f for f in u.flags if f != "-Werror"), "-g", *sanitizers), u.cxx)
        for u in native.units(gen, also=[HARNESS], c_sources=c_sources)
    ]
    objects = compile_units(todo, FUZZ_DIR / "obj", cc=cc, cxx=cxx)
    driver = cxx if any(u.cxx for u in todo) else cc
    return link(objects, FUZZ_DIR / "fuzz_dispatch", [driver, *sanitizers])


def _frame(name: str, seq: int, **fields: object) -> bytes:
    return framing.encode(SCHEMA.messages[name].type, seq, SCHEMA.messages[name].pack(**fields))


def seed_corpus(directory: Path, seed: int = 0) -> int:
    """Valid frames, one conversation per file."""
    rng = random.Random(seed)
    directory.mkdir(parents=True, exist_ok=True)
    files = {
        "hello": _frame("HELLO", 1, protocol=SCHEMA.protocol_version),
        "ping": _frame("PING", 2, payload=rng.randbytes(16)),
        "stats": _frame("GET_STATS", 3),
        "estimator": _frame("GET_ESTIMATOR", 4, index=1),
        "baud": _frame("SET_BAUD", 5, baud=500_000),
        "reset": _frame("RESET", 6, what=SCHEMA.reset_what["STATE"]),
    }
    for name, spec in estimators.estimators().items():
        for mode in spec.modes:
            params = spec.encode_params(spec.param_values({}), mode)
            config = config_requests(spec.c_id, SCHEMA.mode[mode], params)
            conv = b"".join(_frame(req, 1 + i, **fields) for i, (req, fields) in enumerate(config))
            for k in range(4):
                u = [rng.uniform(-50, 50) for _ in spec.inputs] or [1.0]
                conv += _frame(
                    "SAMPLE", len(config) + 1 + k, index=k, inputs=spec.encode_inputs(u, mode)
                )
            files[f"{name}-{mode.lower()}"] = conv
    # A CONFIG in parts (8 parameter bytes a frame), so the fuzzer starts from the staging path.
    rls = estimators.estimators()["rls"]
    block = rls.encode_params(rls.param_values({}), "F32")
    split = config_requests(rls.c_id, SCHEMA.mode["F32"], block, max_body=12)
    files["config-parts"] = b"".join(_frame(req, 1 + i, **f) for i, (req, f) in enumerate(split))
    for name, data in files.items():
        (directory / name).write_bytes(data)
    return len(files)


_STATS = re.compile(r"#(\d+)\s+DONE\s+cov: (\d+) ft: (\d+)")


def run(seconds: float, *, jobs_dir: Path = FUZZ_DIR) -> FuzzResult:
    exe = build()
    corpus = jobs_dir / "corpus"
    seed_corpus(corpus)
    for old in jobs_dir.glob("crash-*"):
        old.unlink()
    proc = subprocess.run(
        [
            str(exe),
            f"-max_total_time={int(seconds)}",
            "-print_final_stats=1",
            f"-artifact_prefix={jobs_dir}/",
            str(corpus),
        ],
        capture_output=True,
        text=True,
    )
    m = _STATS.search(proc.stderr)
    crashes = sorted(jobs_dir.glob("crash-*"))
    if m is None and not crashes:
        raise BuildError(f"the fuzzer stopped unexpectedly:\n{proc.stderr[-2000:]}")
    executions, coverage, features = (int(g) for g in m.groups()) if m else (0, 0, 0)
    return FuzzResult(executions, coverage, features, crashes, seconds)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m vehil.fuzz", description=__doc__)
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args(argv)
    result = run(args.seconds)
    print(
        f"{result.executions:,} executions in {result.seconds:g} s, coverage {result.coverage} "
        f"edges, {result.features} features, {len(result.crashes)} crashes"
    )
    for crash in result.crashes:
        print(f"crash input: {crash}")
    return 1 if result.crashes else 0


if __name__ == "__main__":
    sys.exit(main())
