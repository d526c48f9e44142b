"""MuJoCo runtime: scenes from task specs, robots, cameras, controllers, mechanisms."""
