"""The drivers: procedures that run the consumers and judge what they return. The public
`optimize` (`optimum`) is the solve judged by the checks of `verdict`, with its error
estimate (`error_estimate`) and grids refined to a target accuracy (`accuracy`); `mpc` is the
receding-horizon controller, `measurement` its policy for measured states off the bounds or
the constraints. The package re-exports nothing: `dmoc.optimize` and `dmoc.MPC`
are the public names."""
