"""The drivers: procedures that run the consumers and judge what they return. The public
`optimize` (`optimum`) is the solve judged by the checks of `verdict`, with its error
estimate (`error_estimate`) and grids refined to a target accuracy (`accuracy`); a problem on
SO(3) is solved by `group_optimum` and judged by `group_verdict`, with the figures of
`verdict_checks` that both verdicts share; `mpc` is the
receding-horizon controller, `measurement` its policy for measured states off the bounds or
the constraints, `references` the windows of a tracked plan it moves on; `flow_linearization`
linearizes the discrete step along a trajectory and `riccati` makes LQR gains of it. The
package re-exports nothing: `dmoc.optimize`, `dmoc.MPC`, `dmoc.flow_jacobians` and
`dmoc.tvlqr` are the public names."""
