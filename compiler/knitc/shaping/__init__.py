"""Shaping: Skeleton → StitchGraph. `shape` builds the nodes in `node_order`, each by its
primitive: `sheet` (sheets and tubes, their courses linked by `shapers`), `joint` (short
rows) and `split` (splits and merges), on the shared pieces in `courses`; the IR is
`stitch_graph`."""
