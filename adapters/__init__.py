"""Engine adapters: one file per engine behind the contract in `adapters.base`.

`adapters.registry` names them; `adapters.combination` maps pair materials onto an
engine's combination rule; `adapters/xfails/<engine>.txt` lists known deviations.
"""
