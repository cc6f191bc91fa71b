"""Contact between a rigid body and a solid plane, as plain functions.

- :mod:`~components.contact.geometry`: planes, the lowest point of a disk or sphere, face detection;
- :mod:`~components.contact.impulse`: the frictionless corner impulse, Coulomb-bounded point and face
  impulses (with the Painlevé fallback);
- :mod:`~components.contact.solver`: one contact resolution from an end-of-step state (time of
  contact, bounce or plastic regime, corrections, dissipated energy).

The component wrapping them is :class:`components.ground.SolidGround`.
"""
