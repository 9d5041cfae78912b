"""Fluid ROM: POD-kriging with correction and scaling (Dissertation Sec. 2.4, App. A-B).

One home per name; import from the module that holds it:

* :mod:`.pod` -- :class:`PodBasis` (Eqs. A.9-A.14) and :class:`PodKriging` (Eqs. 2.56-2.59);
* :mod:`.geometry` -- :class:`RomGeometry` (reference panel, grid, deformation modes),
  interpolation from the reference grid, the Eq. (7.6) wall temperature;
* :mod:`.model` -- :class:`RomFluid`, the ROM as a ``FluidModel`` (Eqs. 2.62-2.76);
* :mod:`.io` -- :func:`save_rom` / :func:`load_rom` (``.npz`` of plain arrays, digest);
* :mod:`.snapshots` -- samples of the built-in source, external snapshot files;
* :mod:`.plan` -- OLH plans and the smart ordering of App. B;
* :mod:`.build` -- building a ROM from a build file, NRMSE checks (Eq. 7.7);
* :mod:`.config` -- the schema of ROM build files.

Dependencies run one way: pod, geometry <- model <- io; geometry <- snapshots;
config, plan, snapshots, model <- build.
"""
