"""The serial link to the arm controller.

- :mod:`appliance.arm.protocol`: frames (COBS + CRC-16/CCITT-FALSE), messages, and
  ``obstacles_from_result`` (result -> OBSTACLES within one frame period's bytes);
  the wire format is specified in ``arm/PROTOCOL.md``, with ``arm/test_vectors.json``.
- :mod:`appliance.arm.link`: ``ArmLink``, the sender the run loop uses.
- :mod:`appliance.arm.sim`: ``ArmSim``, a stand-in controller (``appliance arm-sim``).
- ``arm/reference/arm_decode.c``: a C99 receiver for firmware authors.
"""
