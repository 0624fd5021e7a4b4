"""Motion skills: dVRK PSM kinematics, inverse kinematics and trajectory planning."""
