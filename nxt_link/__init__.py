"""NXT telegrams, transports, the brick emulator and trajectory streaming."""
