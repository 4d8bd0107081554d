"""PlatformIO runs this file with its own Python: hand over to the pip `scons` package."""

import SCons.Script

SCons.Script.main()
