"""The language's values and their evaluation, shared by every stage: one arithmetic
(`arith`), the expression evaluator for parameters and properties (`evaluate`) and the
interpreter of action and shaper programs built on it (`interp`)."""
