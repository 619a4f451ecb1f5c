"""Patterning: the stitch graph's instructions and actions. Queries select stitches
(`query`, with `raster`, `grids`), layers write instructions and drawn charts (`pattern`,
`drawing`), `use` attaches stitch actions (`actions`), and `instructions` turns what cannot
be knitted where it is written into plain knits with a warning."""
