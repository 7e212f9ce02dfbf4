"""The exact (sympy) residual-generator design: ``design_bank(..., exact=True)``.

:mod:`~geomfdi.synthesis.exact.design` carries the construction of Hou, Wen & Chen (2011)
out over the rationals or the rational functions of a parametric plant and delivers
:mod:`geomfdi.generators.exact` objects.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.geometry`, :mod:`geomfdi.generators` and the synthesis front end's
dimension checks (:mod:`geomfdi.synthesis.construction`); the front end imports it only
inside ``design_*`` when ``exact=True`` (sympy stays unloaded otherwise).
"""
