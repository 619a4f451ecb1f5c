"""Code generation: Schedule → MachineProgram (`generate`, thesis ch. 6.8), with the bed
model (`bed`), casting on and off (`casting`), the transfer planner (`transfers`), the
steps of stitch actions (`steps`), and knitc's own simulation of the result (`simulate`);
the IR is `machine`."""
