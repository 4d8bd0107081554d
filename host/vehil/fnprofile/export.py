"""A profile in the formats flame-graph tools read: collapsed stacks (Brendan Gregg's
text format: `a;b;c cycles`), speedscope's JSON, and a PNG flame graph (matplotlib)."""

from __future__ import annotations

import json
from pathlib import Path

from vehil.fnprofile.model import Profile


def write_collapsed(profile: Profile, path: Path) -> Path:
    """All windows' self cycles per stack, one stack a line, root first."""
    stacks = sorted(profile.collapsed().items())
    path.write_text("".join(f"{s} {c}\n" for s, c in stacks))
    return path


def write_speedscope(profile: Profile, path: Path, name: str) -> Path:
    """speedscope's file format: one sampled profile whose weights are cycles."""
    frames: list[dict] = []
    index: dict[str, int] = {}
    samples, weights = [], []
    for stack, cycles in sorted(profile.collapsed().items()):
        ids = []
        for fn in stack.split(";"):
            if fn not in index:
                index[fn] = len(frames)
                frames.append({"name": fn})
            ids.append(index[fn])
        samples.append(ids)
        weights.append(cycles)
    total = sum(weights)
    doc = {
        "$schema": "https://www.speedscope.app/file-format-schema.json",
        "exporter": "vehil profile --functions",
        "name": name,
        "activeProfileIndex": 0,
        "shared": {"frames": frames},
        "profiles": [
            {
                "type": "sampled",
                "name": f"{name}: CPU cycles, {profile.windows} {profile.what}(s)",
                "unit": "none",
                "startValue": 0,
                "endValue": total,
                "samples": samples,
                "weights": weights,
            }
        ],
    }
    path.write_text(json.dumps(doc))
    return path


def _tree(profile: Profile, window: int | None) -> dict:
    """Nested {name: [cycles per window (mean, or of one), children]} from the stacks."""
    root: dict = {}
    per = (profile.windows if window is None else 1) * profile.per
    for stack, cycles in profile.collapsed(window).items():
        level = root
        for fn in stack.split(";"):
            node = level.setdefault(fn, [0.0, {}])
            node[0] += cycles / per
            level = node[1]
    return root


def write_flame_png(profile: Profile, path: Path, title: str, window: int | None = None) -> Path:
    """A flame graph: root at the bottom, each bar as wide as its function's inclusive
    cycles (mean per window, or in one window), library routines and interrupts in their
    own colours."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tree = _tree(profile, window)
    total = sum(v[0] for v in tree.values()) or 1.0
    bars: list[tuple[float, int, float, str]] = []

    def lay(level: dict, x0: float, depth: int) -> None:
        x = x0
        for name, (cycles, children) in sorted(level.items()):
            bars.append((x, depth, cycles, name))
            lay(children, x, depth + 1)
            x += cycles

    lay(tree, 0.0, 0)
    depth = max((d for _, d, _, _ in bars), default=0) + 1
    fig, ax = plt.subplots(figsize=(14, 1.2 + 0.32 * depth))
    for x, d, w, name in bars:
        colour = (
            "#bcbddc" if name.startswith("interrupt") else "#fdae6b" if "[" in name else "#9ecae1"
        )
        ax.add_patch(plt.Rectangle((x, d), w, 0.95, facecolor=colour, edgecolor="white", lw=0.5))
        if w / total > 0.03:
            label = f"{name} {w:,.0f}"
            room = int(w / total * 220)
            text = label if len(label) <= room else label[: max(room - 1, 1)] + "…"
            ax.text(x + w / 2, d + 0.47, text, ha="center", va="center", fontsize=7)
    ax.set_xlim(0, total)
    ax.set_ylim(0, depth)
    ax.set_yticks([])
    ax.set_xlabel(
        f"cycles per {profile.what} (mean of {profile.windows * profile.per})"
        if window is None
        else f"cycles in {profile.what} {window}"
    )
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_all(
    profile: Profile, folder: Path, title: str, result_cycles: object = None
) -> dict[str, Path]:
    """profile.md (tables), flame.png, stacks.collapsed, profile.speedscope.json."""
    from vehil.fnprofile.tables import markdown

    folder.mkdir(parents=True, exist_ok=True)
    out = {
        "flame": write_flame_png(profile, folder / "flame.png", title),
        "flame_median": write_flame_png(
            profile,
            folder / "flame-median.png",
            f"{title}: {profile.what} {profile.median_window}, the median one",
            profile.median_window,
        ),
        "collapsed": write_collapsed(profile, folder / "stacks.collapsed"),
        "speedscope": write_speedscope(profile, folder / "profile.speedscope.json", title),
    }
    md = folder / "profile.md"
    md.write_text(markdown(profile, title, result_cycles, png="flame.png"))  # type: ignore[arg-type]
    out["markdown"] = md
    return out
