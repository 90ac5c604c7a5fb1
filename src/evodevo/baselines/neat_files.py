"""NEAT genomes and populations as JSON, never pickled (SPEC §4, §6).

neat-python pickles its genomes and its ``Checkpointer`` gzips a pickle of the whole
population; opening a run folder somebody else sent must not run code from it, so the NEAT
baseline writes JSON instead and rebuilds neat-python's objects from it:

* a **genome** (``best_genome.json``): its id, fitness, node genes (key, bias, response,
  activation, aggregation, ...) and connection genes (key, innovation number, weight,
  enabled), every attribute a gene class declares, plus the text of the neat config file it
  was evolved with (:func:`genome_to_dict`, :func:`genome_from_dict`, :func:`save_genome`,
  :func:`read_genome`);
* a **population** (``checkpoints/neat-checkpoint-{g}.json``, the population before
  generation g is evaluated): its genomes, the species (members, representative, fitness
  history, the next species id), the reproduction's next genome id and ancestors, the
  innovation tracker, the genome config's next node id and the state of Python's ``random``
  (where neat-python draws from), so :func:`restore_population` continues exactly where an
  uninterrupted run would (:func:`save_population`).

Activation and aggregation functions are names looked up in the neat config's own sets, so a
file can only choose among the functions the config allows.
"""

from __future__ import annotations

import json
import random
from itertools import count
from pathlib import Path
from typing import Any

import neat
from neat.species import Species

from evodevo.errors import CheckpointError
from evodevo.runs import atomic_write_text
from evodevo.safe_io import describe_foreign, legacy_error

__all__ = [
    "GENOME_FORMAT",
    "POPULATION_FORMAT",
    "genome_to_dict",
    "genome_from_dict",
    "save_genome",
    "read_genome",
    "save_population",
    "restore_population",
]

GENOME_FORMAT = "evodevo-neat-genome"
POPULATION_FORMAT = "evodevo-neat-population"
_VERSION = 1
_TYPES = {"FloatAttribute": float, "BoolAttribute": bool, "StringAttribute": str}


def _attributes(gene_type: type[Any]) -> list[tuple[str, type[Any]]]:
    """(name, Python type) of every attribute ``gene_type`` declares."""
    out = []
    for a in gene_type._gene_attributes:
        kind = _TYPES.get(type(a).__name__)
        if kind is None:
            raise TypeError(f"{gene_type.__name__}.{a.name} is a {type(a).__name__}")
        out.append((a.name, kind))
    return out


def genome_to_dict(genome: Any) -> dict[str, Any]:
    """A neat-python genome as plain JSON-able data, genes in the genome's order."""
    nodes = [
        {"key": int(k), **{a: getattr(g, a) for a, _ in _attributes(type(g))}}
        for k, g in genome.nodes.items()
    ]
    connections = [
        {
            "key": [int(k[0]), int(k[1])],
            "innovation": int(g.innovation),
            **{a: getattr(g, a) for a, _ in _attributes(type(g))},
        }
        for k, g in genome.connections.items()
    ]
    fitness = None if genome.fitness is None else float(genome.fitness)
    return {
        "key": int(genome.key),
        "fitness": fitness,
        "nodes": nodes,
        "connections": connections,
    }


def _gene_values(
    gene: dict[str, Any], attrs: list[tuple[str, type[Any]]], skip: set[str]
) -> dict[str, Any]:
    names = {a for a, _ in attrs}
    if set(gene) - skip != names:
        raise ValueError(f"a gene has the fields {sorted(gene)}, expected {sorted(names | skip)}")
    out: dict[str, Any] = {}
    for a, kind in attrs:
        v = gene[a]
        if kind is float and isinstance(v, int) and not isinstance(v, bool):
            v = float(v)
        if type(v) is not kind:
            raise ValueError(f"gene field {a!r} is {v!r}, not a {kind.__name__}")
        out[a] = v
    return out


def genome_from_dict(data: Any, config: Any, where: str = "genome") -> Any:
    """Rebuild a neat-python genome of ``config`` (a ``neat.Config``) from :func:`genome_to_dict`.

    Raises:
        CheckpointError: ``data`` is not such a genome, names a function the config lacks, or
            has genes of another structure.
    """
    gc = config.genome_config
    try:
        genome = config.genome_type(int(data["key"]))
        fit = data["fitness"]
        genome.fitness = None if fit is None else float(fit)
        node_attrs = _attributes(gc.node_gene_type)
        for n in data["nodes"]:
            gene = gc.node_gene_type(int(n["key"]))
            for a, v in _gene_values(n, node_attrs, {"key"}).items():
                setattr(gene, a, v)
            for name, known in (
                ("activation", gc.activation_defs),
                ("aggregation", gc.aggregation_function_defs),
            ):
                if hasattr(gene, name) and not known.is_valid(getattr(gene, name)):
                    raise ValueError(f"node {gene.key} names the {name} {getattr(gene, name)!r}")
            genome.nodes[gene.key] = gene
        conn_attrs = _attributes(gc.connection_gene_type)
        for c in data["connections"]:
            key = (int(c["key"][0]), int(c["key"][1]))
            gene = gc.connection_gene_type(key, innovation=int(c["innovation"]))
            for a, v in _gene_values(c, conn_attrs, {"key", "innovation"}).items():
                setattr(gene, a, v)
            genome.connections[key] = gene
    except (KeyError, TypeError, ValueError, IndexError, AssertionError) as exc:
        raise CheckpointError(f"{where} is not a NEAT genome of this config ({exc})") from None
    missing = [k for k in gc.output_keys if k not in genome.nodes]
    if missing:
        raise CheckpointError(f"{where} lacks the output nodes {missing} of its neat config")
    return genome


def _read_json(path: Path, fmt: str, what: str) -> dict[str, Any]:
    if not path.is_file():
        raise CheckpointError(f"{what} {str(path)!r} does not exist; was the NEAT run trained?")
    raw = path.read_bytes()
    foreign = describe_foreign(raw[:9])
    if foreign is not None:
        raise legacy_error(path, foreign)
    try:
        data = json.loads(raw.decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CheckpointError(
            f"{what} {str(path)!r} is corrupt or not JSON ({exc}); it was not written by evodevo"
        ) from None
    if not isinstance(data, dict) or data.get("format") != fmt:
        raise CheckpointError(f"{str(path)!r} is not a {what} written by evodevo (no {fmt!r} tag)")
    if data.get("version") != _VERSION:
        raise CheckpointError(
            f"{what} {str(path)!r} has format version {data.get('version')!r}; this evodevo "
            f"reads version {_VERSION}"
        )
    return data


def save_genome(path: str | Path, genome: dict[str, Any], config_path: str | Path) -> None:
    """Atomically write a genome (as :func:`genome_to_dict`) and its neat config's text."""
    atomic_write_text(
        path,
        json.dumps(
            {
                "format": GENOME_FORMAT,
                "version": _VERSION,
                "genome": genome,
                "neat_config": Path(config_path).read_text(),
            },
            indent=1,
        )
        + "\n",
    )


def read_genome(path: str | Path, config: Any) -> dict[str, Any]:
    """The genome data of a file written by :func:`save_genome`, checked against ``config``."""
    p = Path(path)
    data = _read_json(p, GENOME_FORMAT, "NEAT genome")
    genome_from_dict(data.get("genome"), config, f"NEAT genome {str(p)!r}")
    return dict(data["genome"])


def _next(counter: count[int]) -> int:
    """The value ``counter`` returns next (read by drawing it; the caller replaces it)."""
    return next(counter)


def save_population(path: str | Path, pop: Any, generation: int) -> None:
    """Atomically write ``pop`` (a ``neat.Population`` between generations) as JSON.

    ``generation`` is the next generation to evaluate.
    """
    repro, species_set = pop.reproduction, pop.species
    gc = pop.config.genome_config
    genome_next = _next(repro.genome_indexer)
    repro.genome_indexer = count(genome_next)
    species_next = _next(species_set.indexer)
    species_set.indexer = count(species_next)
    node_next = None
    if gc.node_indexer is not None:
        node_next = _next(gc.node_indexer)
        gc.node_indexer = count(node_next)
    tracker = repro.innovation_tracker
    version, internal, gauss = random.getstate()
    data = {
        "format": POPULATION_FORMAT,
        "version": _VERSION,
        "generation": int(generation),
        "population": [genome_to_dict(g) for g in pop.population.values()],
        "species": {
            "next_id": species_next,
            "species": [
                {
                    "key": int(s.key),
                    "created": int(s.created),
                    "last_improved": int(s.last_improved),
                    "representative": int(s.representative.key),
                    "members": [int(k) for k in s.members],
                    "fitness": s.fitness,
                    "adjusted_fitness": s.adjusted_fitness,
                    "fitness_history": list(s.fitness_history),
                }
                for s in species_set.species.values()
            ],
            "genome_to_species": [
                [int(g), int(s)] for g, s in species_set.genome_to_species.items()
            ],
        },
        "reproduction": {
            "next_genome_id": genome_next,
            "ancestors": [[int(g), [int(p) for p in ps]] for g, ps in repro.ancestors.items()],
        },
        "innovations": {
            "global_counter": int(tracker.global_counter),
            "generation": [[*k, int(v)] for k, v in tracker.generation_innovations.items()],
        },
        "next_node_id": node_next,
        "random_state": [version, list(internal), gauss],
    }
    atomic_write_text(path, json.dumps(data) + "\n")


def restore_population(path: str | Path, config: Any) -> tuple[Any, int]:
    """The ``neat.Population`` of ``config`` saved by :func:`save_population`, and its generation.

    Python's ``random`` gets the saved state (neat-python draws from it).
    """
    p = Path(path)
    data = _read_json(p, POPULATION_FORMAT, "NEAT population")
    where = f"NEAT population {str(p)!r}"
    try:
        generation = int(data["generation"])
        population = {}
        for g in data["population"]:
            genome = genome_from_dict(g, config, where)
            population[genome.key] = genome
        saved = data["species"]
        species_set = config.species_set_type(config.species_set_config, None)
        species_set.indexer = count(int(saved["next_id"]))
        for s in saved["species"]:
            sp = Species(int(s["key"]), int(s["created"]))
            sp.last_improved = int(s["last_improved"])
            sp.representative = population[int(s["representative"])]
            sp.members = {int(k): population[int(k)] for k in s["members"]}
            sp.fitness = s["fitness"]
            sp.adjusted_fitness = s["adjusted_fitness"]
            sp.fitness_history = [float(x) for x in s["fitness_history"]]
            species_set.species[sp.key] = sp
        species_set.genome_to_species = {int(g): int(s) for g, s in saved["genome_to_species"]}
        repro = data["reproduction"]
        innovations = data["innovations"]
        version, internal, gauss = data["random_state"]
        state = (int(version), tuple(int(x) for x in internal), gauss)
        next_node = data["next_node_id"]
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise CheckpointError(f"{where} is corrupt ({type(exc).__name__}: {exc})") from None
    pop = neat.Population(config, (population, species_set, generation))
    pop.reproduction.genome_indexer = count(int(repro["next_genome_id"]))
    pop.reproduction.ancestors = {int(g): tuple(ps) for g, ps in repro["ancestors"]}
    tracker = pop.reproduction.innovation_tracker
    tracker.global_counter = int(innovations["global_counter"])
    tracker.generation_innovations = {
        (int(i), int(o), str(kind)): int(n) for i, o, kind, n in innovations["generation"]
    }
    config.genome_config.innovation_tracker = tracker
    config.genome_config.node_indexer = None if next_node is None else count(int(next_node))
    try:
        random.setstate(state)
    except (TypeError, ValueError) as exc:
        raise CheckpointError(f"{where} has a corrupt random state ({exc})") from None
    return pop, generation
