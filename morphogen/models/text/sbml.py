"""Antimony and SBML mass-action networks in and out (Yamamoto et al. eqs. 2-3).

A file from tellurium, COPASI or any SBML tool becomes a :class:`ReactionNetwork` when every
reaction has a **mass-action** kinetic law

.. math::

    v_j = k_j \\prod_l s_l^{M_e(l, j)}

written as a product of one rate constant ``k_j`` (a global or local parameter with a value, or
one number, then named ``k_<reaction>``), the reactant species each raised to its integer
stoichiometry (``A^2`` or ``A*A``), and optionally compartment symbols. Compartments must have
size 1, so a compartment factor is 1 and concentrations equal amounts. Anything else (another
species, a sum, a function, a rule or event, a boundary or constant species, non-integer
stoichiometry) is refused with one line naming the reaction or element. Species get the
diffusion parameters ``D_<species>``: default 0, or the value of a file parameter of that name.

Antimony text is translated to SBML by libAntimony and then read like SBML; export goes the other
way (SBML written with libSBML, Antimony produced from it by libAntimony).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.models.network import ReactionNetwork, to_toml
from morphogen.util.extras import require
from morphogen.util.io import read_text

ANTIMONY_SUFFIXES = (".ant", ".antimony")
SBML_SUFFIXES = (".xml", ".sbml")
SUFFIXES = ANTIMONY_SUFFIXES + SBML_SUFFIXES
"""File endings :func:`morphogen.models.registry.load_model` reads as networks."""
MAX_STOICHIOMETRY = 100
"""Largest stoichiometric number or rate-law power read (larger ones are refused as typos: a
mass-action term ``s^100`` already under- or overflows float32 for any ``s`` away from 1)."""


def load_network_file(path: str | os.PathLike) -> Model:
    """A model from an Antimony (``.ant``, ``.antimony``) or SBML (``.xml``, ``.sbml``) file.

    The model's ``source`` is its morphogen model file (:func:`to_toml`), so a run records an
    equivalent TOML text and replays without the original file.
    """
    net = read_network_file(path)
    return replace(net.model(), source=to_toml(net))


def read_network_file(path: str | os.PathLike) -> ReactionNetwork:
    """Read an Antimony or SBML file as a :class:`ReactionNetwork` (by its suffix)."""
    path = Path(path)
    text = read_text(path, "network file")
    if path.suffix.lower() in ANTIMONY_SUFFIXES:
        return read_antimony(text, where=str(path))
    return read_sbml(text, where=str(path), name=path.stem)


def read_antimony(text: str, where: str = "Antimony text") -> ReactionNetwork:
    """Translate Antimony to SBML with libAntimony, then :func:`read_sbml`.

    Raises:
        MorphogenError: the text is not Antimony, or it has an ``import`` statement (refused
            before libAntimony sees the text, which would read the named file).
    """
    refuse_imports(text, where)
    antimony = require("antimony", "networks", "reading and writing Antimony")

    antimony.clearPreviousLoads()
    if antimony.loadAntimonyString(text.removeprefix("\ufeff")) < 0:
        message = _brief(_antimony_text(antimony.getLastError) or "")
        raise MorphogenError(f"{where}: {message or 'not Antimony'}")
    module = _antimony_text(antimony.getMainModuleName)
    sbml = _antimony_text(antimony.getSBMLString, module)
    antimony.clearPreviousLoads()
    return read_sbml(sbml, where=where, name=module)


_ANTIMONY_SKIPPED = re.compile(
    r"""//[^\n\r]*|#[^\n\r]*|/\*[\s\S]*?(?:\*/|\Z)|"(?:\\[^\n\r]|[^"\\\n\r])*"|(?P<open>")"""
)
"""What libAntimony does not read as statements: ``//`` and ``#`` comments (to the end of the
line, ``\\r`` included), ``/* */`` comments (not nested; an unclosed one runs to the end) and
double-quoted strings (backslash escapes, never across a line break); group ``open`` is a quote
that no string closes."""
_IMPORT = re.compile(r"(?<![A-Za-z_])import(?![A-Za-z0-9_])")


def refuse_imports(text: str, where: str = "Antimony text") -> None:
    """Raise if Antimony ``text`` has an ``import`` statement outside comments and strings.

    ``import "FILE"`` makes libAntimony open and parse any file the process can read (its
    error messages then quote that file), so network files may not import: they must hold the
    whole model. It is the only Antimony statement that reads a file. The check errs on the
    side of refusing: ``import`` after a digit or a non-ASCII letter counts too, and a quote
    left open on its line (which libAntimony refuses as well) is refused here, so that no
    string can hide what follows it.
    """
    pos = 0
    for skipped in (*_ANTIMONY_SKIPPED.finditer(text), None):
        stop = len(text) if skipped is None else skipped.start()
        found = _IMPORT.search(text, pos, stop)
        if found is not None:
            raise MorphogenError(
                f"{where}: line {_line(text, found.start())}: 'import' is not allowed in a "
                "network file (it would read another file); paste the imported model into "
                "this file instead"
            )
        if skipped is not None and skipped.group("open"):
            raise MorphogenError(f"{where}: line {_line(text, stop)}: a string is not closed "
                                 "on its line; add the closing \"")
        if skipped is not None:
            pos = skipped.end()


def _line(text: str, index: int) -> int:
    """1-based line of ``text[index]``; ``\\n``, ``\\r`` and ``\\r\\n`` end lines."""
    head = text[:index]
    return head.count("\n") + head.count("\r") - head.count("\r\n") + 1


def read_sbml(text: str, where: str = "SBML text", name: str = "network") -> ReactionNetwork:
    """Parse SBML and check every reaction is mass action (see the module docstring).

    Raises:
        MorphogenError: one line naming the file and the element at fault.
    """
    libsbml = require("libsbml", "networks", "reading and writing SBML")

    doc = libsbml.readSBMLFromString(text.removeprefix("\ufeff"))
    log = doc.getErrorLog()
    for i in range(log.getNumErrors()):
        err = log.getError(i)
        if err.isError() or err.isFatal():
            raise MorphogenError(f"{where}: not valid SBML (line {err.getLine()}): "
                                 f"{_brief(err.getMessage())}")
    model = doc.getModel()
    if model is None:
        raise MorphogenError(f"{where}: the SBML document holds no model")
    for kind, count in (("rules", model.getNumRules()), ("events", model.getNumEvents()),
                        ("function definitions", model.getNumFunctionDefinitions()),
                        ("initial assignments", model.getNumInitialAssignments())):
        if count:
            raise MorphogenError(f"{where}: {kind} are not supported; a network file may hold "
                                 "only species, parameters and mass-action reactions")
    return _Reader(model, where).network(model.getId() or name)


class _Reader:
    """Turns one libSBML model into a :class:`ReactionNetwork`."""

    def __init__(self, model, where: str):
        self.model, self.where = model, where
        self.species = [s.getId() for s in model.getListOfSpecies()]
        self.compartments = {c.getId() for c in model.getListOfCompartments()}
        self.params = {p.getId(): p for p in model.getListOfParameters()}

    def fail(self, message: str) -> MorphogenError:
        return MorphogenError(f"{self.where}: {message}")

    def network(self, name: str) -> ReactionNetwork:
        species = self.species
        for c in self.model.getListOfCompartments():
            if c.isSetSize() and c.getSize() != 1.0:
                raise self.fail(f"compartment {c.getId()} has size {c.getSize():g}; mass-action "
                                "networks are read with compartments of size 1")
        if not species:
            raise self.fail("the model has no species")
        for s in self.model.getListOfSpecies():
            if s.getBoundaryCondition() or s.getConstant():
                raise self.fail(f"species {s.getId()} is a boundary or constant species; make it "
                                "a parameter or an ordinary species")
        n, m = len(species), self.model.getNumReactions()
        if m == 0:
            raise self.fail("the model has no reactions")
        me, mp = np.zeros((n, m), np.int64), np.zeros((n, m), np.int64)
        ids, rate_names, rates = [], [], []
        for j, rx in enumerate(self.model.getListOfReactions()):
            rid = rx.getId()
            ids.append(rid)
            for refs, mat in ((rx.getListOfReactants(), me), (rx.getListOfProducts(), mp)):
                for ref in refs:
                    if ref.getSpecies() not in species:
                        raise self.fail(f"reaction {rid}: unknown species {ref.getSpecies()!r}")
                    mat[species.index(ref.getSpecies()), j] += self._stoichiometry(rid, ref)
            k_name, k = self._mass_action(rx, me[:, j])
            rate_names.append(k_name)
            rates.append(k)
        diffusion = tuple(self._value(f"D_{s}", 0.0) for s in species)
        initial = [self._initial(s) for s in self.model.getListOfSpecies()]
        return ReactionNetwork(
            name, tuple(species), me, mp, tuple(ids), tuple(rate_names), tuple(rates),
            diffusion, initial=None if None in initial else tuple(initial), display=species[0],
            description=f"mass-action network read from {Path(self.where).name}",
            reference=f"network file {self.where}")

    def _stoichiometry(self, rid: str, ref) -> int:
        value = ref.getStoichiometry() if ref.isSetStoichiometry() else 1.0
        if ref.isSetStoichiometryMath():
            raise self.fail(f"reaction {rid}: stoichiometry given by a formula; use integers")
        if not _whole(value, 0):
            raise self.fail(f"reaction {rid}: stoichiometry {value:g} of {ref.getSpecies()} is "
                            f"not an integer from 0 to {MAX_STOICHIOMETRY}")
        return int(value)

    def _finite(self, what: str, value: float, low: float = -math.inf) -> float:
        if not math.isfinite(value) or value < low:
            bound = "a finite number" if low == -math.inf else f"a finite number >= {low:g}"
            raise self.fail(f"{what} is {value:g}; give it {bound}")
        return float(value)

    def _value(self, name: str, default: float) -> float:
        p = self.params.get(name)
        if p is None or not p.isSetValue():
            return default
        return self._finite(f"diffusion coefficient {name}", p.getValue(), low=0.0)

    def _initial(self, s) -> float | None:
        for is_set, get in ((s.isSetInitialConcentration, s.getInitialConcentration),
                            (s.isSetInitialAmount, s.getInitialAmount)):
            if is_set():
                return self._finite(f"initial value of {s.getId()}", get())
        return None

    def _mass_action(self, rx, educts: np.ndarray) -> tuple[str, float]:
        """The rate constant of ``rx`` after checking its law is ``k Π s^e``."""
        libsbml = require("libsbml", "networks", "reading and writing SBML")

        rid = rx.getId()
        law = rx.getKineticLaw() if rx.isSetKineticLaw() else None
        if law is None or law.getMath() is None:
            raise self.fail(f"reaction {rid} has no rate law")
        text = libsbml.formulaToL3String(law.getMath())
        refuse = self.fail(f"reaction {rid}: rate law {text!r} is not mass action (one rate "
                           "constant times each reactant to the power of its stoichiometry)")
        local = {p.getId(): p for p in law.getListOfParameters()}
        powers = np.zeros_like(educts)
        constants: list[str | float] = []
        for node, exponent in _factors(law.getMath(), refuse):
            if node.isNumber():
                constants.append(float(node.getValue()) ** exponent)
                continue
            name = node.getName()
            if name in self.species and name not in local:
                powers[self.species.index(name)] += exponent
            elif name in self.compartments:
                continue
            elif name in local or name in self.params:
                if not (local.get(name) or self.params[name]).isSetValue():
                    raise self.fail(f"reaction {rid}: rate law uses {name!r}, which has no "
                                    "value; declare it as a species or give it a value")
                if exponent != 1:
                    raise refuse
                constants.append(name)
            else:
                raise self.fail(f"reaction {rid}: rate law uses {name!r}, which is neither a "
                                "species nor a parameter")
        if len(constants) != 1 or not np.array_equal(powers, educts):
            raise refuse
        k = constants[0]
        if isinstance(k, float):
            return f"k_{rid}", self._finite(f"reaction {rid}: rate constant", k)
        p = local.get(k) or self.params[k]
        if k in local and k in self.params:
            k = f"{rid}_{k}"
        return k, self._finite(f"reaction {rid}: rate constant {k}", p.getValue())


def _whole(value: float, low: int) -> bool:
    """Whether ``value`` is an integer from ``low`` to :data:`MAX_STOICHIOMETRY`."""
    return math.isfinite(value) and value == int(value) and low <= value <= MAX_STOICHIOMETRY


def _factors(root, refuse: MorphogenError) -> list:
    """``[(leaf, exponent)]`` of a product of names, numbers and integer powers of them
    (walked with a stack, so a deeply nested law is refused rather than overflowing Python's)."""
    libsbml = require("libsbml", "networks", "reading and writing SBML")

    out, stack = [], [(root, 1)]
    while stack:
        node, exponent = stack.pop()
        kind = node.getType()
        if kind == libsbml.AST_TIMES:
            stack += [(node.getChild(i), exponent) for i in range(node.getNumChildren())]
        elif kind in (libsbml.AST_POWER, libsbml.AST_FUNCTION_POWER) \
                and node.getNumChildren() == 2:
            base, power = node.getChild(0), node.getChild(1)
            if not power.isNumber() or not _whole(power.getValue(), 1) \
                    or base.getType() == libsbml.AST_TIMES:
                raise refuse
            exponent *= int(power.getValue())
            if exponent > MAX_STOICHIOMETRY:
                raise refuse
            stack.append((base, exponent))
        elif node.isNumber() or kind == libsbml.AST_NAME:
            out.append((node, exponent))
        else:
            raise refuse
    return out


def to_sbml(net: ReactionNetwork) -> str:
    """SBML Level 3 Version 2 of the network: one compartment of size 1, species with initial
    concentrations, rate parameters, the parameters ``D_<species>`` (read back on import), and
    each reaction's mass-action law ``k * Π s^e``."""
    libsbml = require("libsbml", "networks", "reading and writing SBML")

    doc = libsbml.SBMLDocument(3, 2)
    model = doc.createModel()
    model.setId(_sbml_id(net.name))
    comp = model.createCompartment()
    comp.setId("cell")
    comp.setSize(1.0)
    comp.setConstant(True)
    comp.setSpatialDimensions(3)
    initial = net.initial or (0.0,) * len(net.species)
    for s, v in zip(net.species, initial, strict=True):
        sp = model.createSpecies()
        sp.setId(s)
        sp.setCompartment("cell")
        sp.setInitialConcentration(float(v))
        sp.setHasOnlySubstanceUnits(False)
        sp.setBoundaryCondition(False)
        sp.setConstant(False)
    for name, value in net.parameters.items():
        p = model.createParameter()
        p.setId(name)
        p.setValue(value)
        p.setConstant(True)
    me, mp = np.asarray(net.educts), np.asarray(net.products)
    for j, rid in enumerate(net.reaction_ids):
        rx = model.createReaction()
        rx.setId(rid)
        rx.setReversible(False)
        for mat, add in ((me, rx.createReactant), (mp, rx.createProduct)):
            for i in np.flatnonzero(mat[:, j]):
                ref = add()
                ref.setSpecies(net.species[i])
                ref.setStoichiometry(float(mat[i, j]))
                ref.setConstant(True)
        factors = [net.rate_names[j]] + [
            net.species[i] if me[i, j] == 1 else f"{net.species[i]}^{me[i, j]}"
            for i in np.flatnonzero(me[:, j])]
        rx.createKineticLaw().setMath(libsbml.parseL3Formula(" * ".join(factors)))
    return libsbml.writeSBMLToString(doc)


def to_antimony(net: ReactionNetwork) -> str:
    """Antimony text of the network, made by libAntimony from :func:`to_sbml`."""
    antimony = require("antimony", "networks", "reading and writing Antimony")

    antimony.clearPreviousLoads()
    if antimony.loadSBMLString(to_sbml(net)) < 0:
        raise MorphogenError(f"network {net.name!r}: Antimony export failed: "
                             + _brief(_antimony_text(antimony.getLastError) or ""))
    text = antimony.getAntimonyString(None)
    antimony.clearPreviousLoads()
    return text


def _antimony_text(call, *args) -> str | None:
    """A libAntimony string result; its bytes may end inside a UTF-8 character (libAntimony cuts
    error messages by bytes), which the binding's strict decoding would raise on."""
    try:
        return call(*args)
    except UnicodeDecodeError as err:
        return err.object.decode("utf-8", errors="replace")


def _brief(message: str, limit: int = 240) -> str:
    """A library's error message on one line, cut to ``limit`` characters."""
    text = " ".join(message.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _sbml_id(name: str) -> str:
    """An SBML SId from a model name (letters, digits, ``_``; not starting with a digit)."""
    out = "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in name)
    return out if out and not out[0].isdigit() else f"m_{out}"
