"""Vendored libraries' manifests (third_party/NAME/vehil-lib.toml): what a build compiles
and with which flags, and errors that name the file and the key."""

from pathlib import Path

import pytest

from vehil.build import vendored
from vehil.errors import BuildError


def _library(root: Path, manifest: str, files: dict[str, str]) -> Path:
    folder = root / "third_party" / "filt"
    folder.mkdir(parents=True)
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    (folder / vendored.MANIFEST).write_text(manifest)
    return folder


def test_only_the_listed_sources_are_built_with_the_manifests_flags(tmp_path: Path) -> None:
    folder = _library(
        tmp_path,
        '[library]\nsources = ["src/*.c"]\ninclude_dirs = ["src"]\ndefines = ["FILT_N=2", "X"]\n'
        'warnings = ["-Wno-unused-parameter"]\nstandard = "gnu11"\n',
        {"src/filt.c": "", "src/filt.h": "", "examples/demo/demo.c": "int main(void){}"},
    )
    [lib] = vendored.libraries([tmp_path])
    assert lib.name == "filt" and not lib.cxx
    assert lib.sources == (folder / "src" / "filt.c",)  # the example's main is not built
    assert lib.own_flags() == ["-std=gnu11", "-Wno-error", "-Wno-unused-parameter"]
    flags = vendored.include_flags([lib])
    assert ["-isystem", str(folder / "src")] == flags[2:4]
    assert flags[-2:] == ["-DFILT_N=2", "-DX"]


@pytest.mark.parametrize(
    ("manifest", "files", "message"),
    [
        ('[library]\nsources = ["src/*.c"]\n', {}, "library.sources: 'src/*.c' matches no file"),
        (
            '[library]\nlanguage = "c"\nsources = ["a.cpp"]\n',
            {"a.cpp": ""},
            "a.cpp is not a c source",
        ),
        ('[library]\nlanguage = "rust"\n', {}, "library.language: 'rust'"),
        ('[library]\nsource = ["a.c"]\n', {}, "library.source: unknown key"),
        ('[library]\ninclude_dirs = ["inc"]\n', {}, "library.include_dirs: no folder"),
        ('[library]\ndefines = ["-DX"]\n', {}, "library.defines: '-DX' is not NAME"),
        ('[library]\nwarnings = ["-O0"]\n', {}, "library.warnings: '-O0' is not a -W flag"),
        ("[lib]\n", {}, "give one [library] table"),
    ],
)
def test_a_wrong_manifest_is_refused_naming_the_key(
    tmp_path: Path, manifest: str, files: dict[str, str], message: str
) -> None:
    folder = _library(tmp_path, manifest, files)
    with pytest.raises(BuildError) as err:
        vendored.libraries([tmp_path])
    assert str(folder / vendored.MANIFEST) in str(err.value) and message in str(err.value)


def test_two_libraries_of_one_name_are_refused(tmp_path: Path) -> None:
    for root in (tmp_path / "a", tmp_path / "b"):
        _library(root, "[library]\n", {})
    with pytest.raises(BuildError, match="two vendored libraries named filt"):
        vendored.libraries([tmp_path / "a", tmp_path / "b"])
