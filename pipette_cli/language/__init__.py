"""What both language front-ends share (``pipette agent`` and ``pipette new-task``): words and
phrase matching (:mod:`.phrases`), the one clause splitter (:mod:`.clauses`), the lexicon built
from the registries (:mod:`.lexicon`: robots, suites, tasks; :mod:`.assets`: asset kinds and
their aliases) and the mention resolver (:mod:`.mentions`). The two typed grammars sit on top:
the workflow plan (:mod:`pipette_cli.agent`) and the task plan (:mod:`pipette_cli.authoring`);
LLM backends and the repair loop are :mod:`pipette_cli.llm`'s."""
