"""PlatformIO pre-script: stamp the image with the git revision it was built from, and
write the registry of the estimators the env's custom_estimators names."""

from pathlib import Path

Import("env")  # noqa: F821  (SCons injects it)

from vehil.build import registry  # noqa: E402
from vehil.build.build_id import build_id_defines  # noqa: E402

env.Append(CPPDEFINES=build_id_defines())  # noqa: F821
gen = Path(env.subst("$BUILD_DIR")) / "gen"  # noqa: F821
registry.write(gen, registry.select(env.GetProjectOption("custom_estimators", "all")))  # noqa: F821
env.Append(CPPPATH=[str(gen)])  # noqa: F821
