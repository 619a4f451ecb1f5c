"""Front end: source text → AST (`parser`, the dataclass tree in `ast`, the canonical
printer `fmt`) → Skeleton (`resolve`: imports, parameters, properties, topology; the IR in
`skeleton`)."""
