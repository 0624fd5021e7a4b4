"""The FLS pegboard's count of pegs: what a tree's peg parameters are checked against, without reading the
work cell's geometry (`pegbt.workcell`, which lays the pegs out)."""

N_PEGS = 12
