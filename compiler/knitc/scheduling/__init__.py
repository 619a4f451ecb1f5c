"""Scheduling: StitchGraph → Trace (`tracing`; the IR `trace`) → Slices (`slicing`; the IR
`slices`) → Schedule (`scheduler`: layouts and needle offsets; the IR `schedule`)."""
