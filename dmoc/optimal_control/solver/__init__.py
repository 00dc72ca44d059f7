"""The solution of the nonlinear program: `solve` (module `solving`) runs IPOPT (`ipopt`,
its linear solver's journal `linear_solver`) from a start point (`guess`, `waypoints`),
with bounds fixed on multipliers (`fixed_multipliers`), Ctrl-C handled (`interrupt`) and the
worst violated rows found (`violation`); its outcome is an `optimization_result` carrying the
`Verdict` record (`verdict_record`)."""
