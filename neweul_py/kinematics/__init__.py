"""kinematics layer (see DESIGN.md)."""
