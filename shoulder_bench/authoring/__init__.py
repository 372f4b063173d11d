"""Authoring: the code that makes the shipped model files, from anatomy to tables.

anatomy / mobl_data / references (the data) -> bones (meshes), mjcf (v1) and mobl (v2) MJCF writers -> kinematics,
tendons, statics_v2 (geometry and static estimates of v2) -> hill, hill_v2 and fem/ (the muscle tables) ->
validate, validate_v2, validate_report (the model against the references). The runtime (`shoulder_bench.model`,
`muscle`, `arm`, ...) reads what these write and never imports them.
"""
