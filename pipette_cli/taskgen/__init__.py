"""A typed task plan (:class:`.plan.TaskPlanSpec`) -> a registry task: the plan checked against
the asset library and the robot (:mod:`.validate`), the scene laid out (:mod:`.scene`,
:mod:`.layout`), each step turned into a success stage and skill steps (:mod:`.stages`), the YAML
rendered (:mod:`.render`) and the expert checked in simulation (:mod:`.check`).

Nothing here reads words: ``pipette new-task`` (:mod:`pipette_cli.authoring`) turns a description
into the plan, and any other front-end may build one."""
