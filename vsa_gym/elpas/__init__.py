"""The eLPAS variable-geometry active suspension actuator (cone kinematics, drive, rig and vehicle models)."""
