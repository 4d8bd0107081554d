"""PlatformIO pre-script: stamp the image with the revision it was built from, write the
registry of the estimators the env's custom_estimators names, compile a project's C
(custom_c_sources: folders, from vehil.toml's c_sources) into the image, give each
language its own [vehil] flags, and build the vendored libraries (vehil/build/vendored.py)."""

import shlex
from pathlib import Path

Import("env")  # noqa: F821  (SCons injects it)

from SCons.Script import DefaultEnvironment  # noqa: E402

from vehil.build import registry, vendored  # noqa: E402
from vehil.build.build_id import build_id_defines  # noqa: E402
from vehil.paths import DATA_ROOT  # noqa: E402

env.Append(CPPDEFINES=build_id_defines())  # noqa: F821
c_sources = [Path(p) for p in env.GetProjectOption("custom_c_sources", "").split()]  # noqa: F821
gen = Path(env.subst("$BUILD_DIR")) / "gen"  # noqa: F821
chosen = registry.select(env.GetProjectOption("custom_estimators", "all"), c_sources)  # noqa: F821
registry.write(gen, chosen, c_sources)
env.Append(CPPPATH=[str(gen), *map(str, c_sources)])  # noqa: F821
for i, folder in enumerate(c_sources):
    env.BuildSources(f"$BUILD_DIR/project{i}", str(folder))  # noqa: F821

config = env.GetProjectConfig()  # noqa: F821
env.Append(  # noqa: F821
    CFLAGS=shlex.split(config.get("vehil", "c_flags")),
    CXXFLAGS=shlex.split(config.get("vehil", "cxx_flags")),
)

# The third_party/ folders: vehil's, and a project's (custom_vendored, from vehil build)
roots = [Path(p) for p in env.GetProjectOption("custom_vendored", "").split()]  # noqa: F821
libs = vendored.libraries(roots or [DATA_ROOT])
env.Append(CCFLAGS=vendored.include_flags(libs))  # noqa: F821
objects = []
for lib in libs:
    for source in lib.sources:
        target = Path("$BUILD_DIR", vendored.FOLDER, lib.name, source.relative_to(lib.root))
        # An override of CPPFLAGS only: it comes after CCFLAGS on the command line (so
        # -Wno-error and the library's standard win) and leaves every other flag the env's
        objects += env.Object(  # noqa: F821
            str(target.with_suffix(".o")), str(source), CPPFLAGS=lib.own_flags()
        )
DefaultEnvironment().Append(PIOBUILDFILES=objects)
