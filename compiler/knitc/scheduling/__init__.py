"""Scheduling: StitchGraph → Trace (`tracing`; the IR `trace`) → Slices (`slicing`; the IR
`slices`) → Schedule (`scheduler`, which runs `layouts` then `offsets` over the slices'
`relations`; the IR `schedule`)."""
