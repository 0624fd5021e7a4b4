"""`pegbt eval`: many seeded peg-transfer trials on the embedded simulator, judged by its ground truth,
summarised as the reference paper's tables and figure, with injected faults traced to their causes.

`trial` runs one trial and distils it into plain data; `campaign` runs many in worker processes;
`truth` reads the simulator's event log (what failed, which faults were injected and recovered);
`why` checks that `pegbt log why` names the same step and cause; `faultgen` writes a fault plan per
seed; `summary` computes the figures beside the paper's (`paper`); `output` writes CSV and box plots.
"""
