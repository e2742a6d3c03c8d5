"""What a part's state array is laid out over, on one rank (for checkpoints).

A stateful part (the kinematics, the material points, the tool) gives its
state as named ``(kind, array)`` pairs; the array's first axis runs over this
rank's entities of that kind, ghosts included. ``app.checkpoint`` stores each
kind by the mesh's input cell numbering (or, for contact points, by their face
and place), so a checkpoint does not depend on how the mesh was distributed.
"""
#: The unknown's dofs (a flat array, block after block of ``disc.space``).
DOFS = "dofs"
#: The quadrature points, cell by cell.
POINTS = "points"
#: The mesh geometry's nodes.
NODES = "nodes"
#: The tool's contact points on this rank.
CONTACT = "contact"
#: One value, the same on every rank.
GLOBAL = "global"
