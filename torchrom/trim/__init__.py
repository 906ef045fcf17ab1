"""Static aeroelastic equilibrium (Nastran's SOL 144, and SOL 106/400 under the steady loads):
the coupling of the FE model (:mod:`torchrom.fe`) and the steady panel aerodynamics
(:mod:`torchrom.aero.steady`), above both.

- :mod:`.operators`: the steady aerodynamic load on an FE model's DOFs through the deck's
  splines: a rigid root incidence and the aerodynamic stiffness of the deflection;
- :mod:`.equilibrium`: the linear (SOL 144) and geometrically nonlinear equilibria, continued
  in speed.
"""
