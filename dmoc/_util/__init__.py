"""What every stage uses and no stage owns: argument validation with one message format
(`checks`), bounded caches (`cache`), atomic files (`files`), evaluating a user's callable on
symbols (`symbolic`) and named layouts of stacked vectors (`layout`)."""
