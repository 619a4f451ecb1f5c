"""knitc.grammars: the Lark grammar(s) of the knitc language, shipped as package data.

This directory is installed as the subpackage ``knitc.grammars`` (see ``package-dir`` in
pyproject.toml). Read grammars with :func:`knitc.resources.grammar_text`, never by a path
relative to the repository.
"""
