"""Shaping: Skeleton → StitchGraph. Nodes are built in `node_order`, each primitive's
courses and wales in `shape` (sheets, joints, splits), the wales between courses of
different widths by `shapers`; the IR is `stitch_graph`."""
