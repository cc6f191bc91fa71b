"""Rigid-body physics as plain functions of (parameters, state, inputs, dt), on float tuples.

- :mod:`~components.rigid.vec`, :mod:`~components.rigid.quaternion`: 3-vectors and unit quaternions;
- :mod:`~components.rigid.shapes`: disk and sphere mass and inertia about the centre of mass;
- :mod:`~components.rigid.dynamics`: state, world inertia, Euler's equations, exact torque-free
  rotation, impulses, energies;
- :mod:`~components.rigid.integrators`: the integrator registry (verlet, semi_implicit_euler, rk4);
- :mod:`~components.rigid.script`: piecewise-linear keyframes for scripted motion.

The component wrapping them is :class:`components.rigid_body.RigidBody`.
"""
