"""Tool–soil interfaces: the interface law and its nodal penalty assembly."""
