"""The shared model of the world, free of any simulator: HERB's numbers and kinematics, the
arm's collision geometry, object specs, surfaces, the scene format and noise model, planar and
3D transforms, the one fcl collision layer, the trajectory and observation formats. The env
(`clutter_gym.env`), the planners and the agents all build on it; importing it never loads
pybullet."""
