"""The wire protocol: schema, COBS, CRC-16 and frames."""
