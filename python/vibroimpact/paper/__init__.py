"""The paper reproduced (docs/paper-cases.md): its cases, ``vibroimpact reproduce`` and the
report of ``reproduce all``. Built on the public API only; nothing of the engine imports it."""
