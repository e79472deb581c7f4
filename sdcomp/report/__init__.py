"""Looking at datasets: contact sheets (:mod:`~sdcomp.report.sheet`) and statistics
(:mod:`~sdcomp.report.stats`)."""
