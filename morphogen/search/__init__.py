"""Search for model parameters: strategies (GA, CMA-ES, MAP-Elites), fitness functions,
gradient fitting and the run archive; network evolution is morphogen.search.networks."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "optimise": "morphogen.search.api",
    "SearchResult": "morphogen.search.api",
    "evolve": "morphogen.search.run",
    "start": "morphogen.search.run",
    "make_strategy": "morphogen.search.run",
    "RunResult": "morphogen.search.run",
    "Problem": "morphogen.search.evaluate",
    "Evaluator": "morphogen.search.evaluate",
    "Gene": "morphogen.search.genes",
    "GeneticAlgorithm": "morphogen.search.ga",
    "CMAES": "morphogen.search.cmaes",
    "MapElites": "morphogen.search.mapelites",
    "CVTMapElites": "morphogen.search.cvt",
    "Archive": "morphogen.search.archive",
    "fit": "morphogen.search.gradient",
    "FitResult": "morphogen.search.gradient",
    "dirichlet_fitness": "morphogen.search.fitness",
    "target_fitness": "morphogen.search.fitness",
    "Strategy": "morphogen.search.strategy",
})
