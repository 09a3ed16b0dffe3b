"""Onboarding a robot: ``placement robots init`` proposes a preset from a URDF or xacro file
(:mod:`~placement.robots.onboarding.propose`), ``placement robots check`` says what a preset reaches
(:mod:`~placement.robots.onboarding.check`). Nothing at run time imports this package."""
