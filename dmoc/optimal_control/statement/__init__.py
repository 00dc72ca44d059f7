"""The statement of an optimal control problem as the user gives it: the problem
(`problem`), its boundary rows (`boundary`), its final time (`final_time`), its parameters
(`parameters`), its read-only views (`read_only`) and the built-in example problems
(`examples`, public as `dmoc.problems`)."""
