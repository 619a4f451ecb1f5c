"""Backends: printers from the machine-program IR to machine formats (Knitout; DAT later)."""
