"""Scene geometry, continuous collision checks, kinematics and trajectory export."""
