"""pyserial URL handlers of vehil's own (`native://`, `faults://`, `mega16u2://`, `tcp://`),
registered on import.

pyserial looks a URL's scheme up as `<package>.protocol_<scheme>` in
`serial.protocol_handler_packages`; adding this package there makes
`serial.serial_for_url("native://")` return the in-process board.
"""

import serial

if __name__ not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append(__name__)
