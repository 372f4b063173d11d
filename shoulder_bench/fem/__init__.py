"""Offline thin-shell (membrane) FEM of the four muscles, reduced to the force tables the MuJoCo callback reads.

material (Blemker fibres, co-rotational background) -> membrane (CST element) -> solver (Newton, contact) ->
shells (meshes from anatomy) -> build (tables) -> verify (held-out points, literature bands, figure); cli wires
`shoulder-bench fem build|verify`. See docs/fem.md.
"""
CODE_VERSION = "1"  # bump when a change alters solutions; it is part of every table's input hash
