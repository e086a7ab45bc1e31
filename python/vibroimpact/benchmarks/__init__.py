"""``vibroimpact bench``: the engine's speed on the paper's and the large models, and the peer
drivers (SciPy, OpenSeesPy, Exudyn). Built on the public API only; nothing of the engine
imports it."""
