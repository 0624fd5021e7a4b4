"""What the leaves share, built once per run by the executive's providers: the `robot` (arms, camera,
clock, the trial's record), the `skills` (per-arm motion under the run's condition, perception) and the
per-arm motion state `ArmMotion` that the skills hold."""
