"""Front end: source text → AST (`parser`, the dataclass tree in `ast`, the canonical
printer `fmt`) → Skeleton (`resolve`: parameters, properties and topology, with imports
and definitions in `definitions` and the name checking of bodies in `names`; the IR in
`skeleton`)."""
