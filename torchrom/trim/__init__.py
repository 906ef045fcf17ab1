"""Static aeroelastic equilibrium (Nastran's SOL 144, and SOL 106/400 under the steady loads):
the coupling of the FE model (:mod:`torchrom.fe`) and the steady panel aerodynamics
(:mod:`torchrom.aero.steady`), above both.

- :mod:`.operators`: the steady aerodynamic load on an FE model's DOFs through the deck's
  splines: a rigid root incidence and the aerodynamic stiffness of the deflection;
- :mod:`.equilibrium`: the linear (SOL 144) and geometrically nonlinear equilibria, continued
  in speed;
- :mod:`.modes`, :mod:`.flutter`: the FE tangent's modes and flutter about an equilibrium;
- :mod:`.reduced`: the ROM's equilibrium, tangent and flutter about a deformed state
  (``torchrom flutter ROM AERO --aoa``);
- :mod:`.condensed`: the FE's exact condensation at the same state, the check on that ROM.
"""
