"""PlatformIO pre-script: stamp the image with the git revision it was built from."""

Import("env")  # noqa: F821  (SCons injects it)

from vehil.build.build_id import build_id_defines  # noqa: E402

env.Append(CPPDEFINES=build_id_defines())  # noqa: F821
