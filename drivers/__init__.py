"""Hardware I/O layer: shaker and DAQ contracts, backends and device emulators."""
