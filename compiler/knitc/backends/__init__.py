"""Backends: MachineProgram ↔ machine files. Knitout out (`knitout`) and in
(`knitout_read`); Shima Seiki DAT through its IR (`dat`): the writer (`dat_write`), the
container (`dat_format`) and the reader back to operations (`dat_read`)."""
