"""PlatformIO pre-script: stamp the image with the revision it was built from, write the
registry of the estimators the env's custom_estimators names, and compile a project's C
(custom_c_sources: folders, from vehil.toml's c_sources) into the image."""

from pathlib import Path

Import("env")  # noqa: F821  (SCons injects it)

from vehil.build import registry  # noqa: E402
from vehil.build.build_id import build_id_defines  # noqa: E402

env.Append(CPPDEFINES=build_id_defines())  # noqa: F821
c_sources = [Path(p) for p in env.GetProjectOption("custom_c_sources", "").split()]  # noqa: F821
gen = Path(env.subst("$BUILD_DIR")) / "gen"  # noqa: F821
chosen = registry.select(env.GetProjectOption("custom_estimators", "all"), c_sources)  # noqa: F821
registry.write(gen, chosen, c_sources)
env.Append(CPPPATH=[str(gen), *map(str, c_sources)])  # noqa: F821
for i, folder in enumerate(c_sources):
    env.BuildSources(f"$BUILD_DIR/project{i}", str(folder))  # noqa: F821
