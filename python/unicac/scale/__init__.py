"""Scale-out of the embarrassingly parallel stages on Ray (`unicac-ray`, docs/scale.md).

The single-machine `unicac` CLI stays the reference: every Ray task runs the CLI on its part of the work
(one specification of a design grid, a batch of lenses, one dataset shard) and the driver merges the
parts into exactly the files the single-machine command writes. Nothing here schedules: Ray places and
retries the tasks; this package only splits, runs and merges.

Modules: `tasks` (running the CLI inside a Ray task, the fault-injection hook),
`session` (starting or joining Ray, a bounded window of tasks with progress), `design`, `ode`, `dataset`,
`tolerance` (one per stage) and `cli` (the `unicac-ray` command).
"""
