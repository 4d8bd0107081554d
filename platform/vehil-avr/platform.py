from platformio.public import PlatformBase


class VehilavrPlatform(PlatformBase):
    """The toolchain is the system's (Debian gcc-avr, avr-libc, binutils-avr): no packages."""
