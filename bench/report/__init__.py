"""Reporting: run directories read back from their files, labelled, laid out as the paper's tables
(Markdown, LaTeX, CSV), plotted, and gathered into one report. Imports :mod:`catpose.bench.run`,
:mod:`catpose.bench.protocols` and :mod:`catpose.bench.scoring`."""
