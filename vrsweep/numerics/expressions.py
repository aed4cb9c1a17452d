"""The expression language of written models: parsed from Python's syntax tree through a whitelist.

    numbers, the model's names (x, v, t and its parameters), pi,
    + - * / ** and unary minus, parentheses,
    sin cos tan exp log sqrt abs tanh sign min max

A config is data and never runs code: the text is parsed (``ast.parse(mode="eval")``, which only
builds a tree) and every node is checked against the whitelist before anything else looks at it;
nothing is ever passed to ``eval``. Attributes, subscripts, calls of anything but the functions
above, lambdas, comprehensions, strings, keywords and unknown names are each refused with the
offending token. The same tree is then read three ways: :func:`names_in` (what it refers to),
:func:`evaluate` (numpy, for the expressions of the parameters alone: period, barriers, response)
and :func:`to_sympy` (the acceleration, whose derivatives written.py derives symbolically).

Plain Python and numpy: the config layer checks expressions without importing sympy or numba.
"""

from __future__ import annotations

import ast
import math
import unicodedata

import numpy as np

from vrsweep.errors import clip
from vrsweep.numbertext import beyond_double

MAX_LENGTH = 2000   # characters: an equation of motion is a line, not a program
MAX_DEPTH = 60      # nesting of the syntax tree (parentheses, operators, calls)
MAX_EXPONENT = 64   # a constant power beyond this is a typo (and x**10**9 would never finish)

# The kinks and jumps (abs, sign, min, max of x, v or t) the kernel locates: a bit each of an int64
# held in a double, exact up to 2**53 (codegen.switching_functions).
MAX_SWITCHES = 52
SWITCHES = ("abs", "sign", "min", "max")
FUNCTIONS = ("sin", "cos", "tan", "exp", "log", "sqrt", "abs", "tanh", "sign", "min", "max")
CONSTANTS = {"pi": math.pi}
STATE_NAMES = ("x", "v", "t")
RESERVED = frozenset(FUNCTIONS) | frozenset(CONSTANTS) | frozenset(STATE_NAMES)

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_UNARY = {ast.USub: "-", ast.UAdd: "+"}


class ExpressionError(ValueError):
    """A problem with an expression, worded for one line after the field's name."""


def parse(text, names) -> ast.expr:
    """The checked syntax tree of ``text``, whose names must be in ``names`` (plus pi and the
    functions); raises ExpressionError naming the offending token."""
    if not isinstance(text, str):
        raise ExpressionError(f"must be an expression written as a string, e.g. \"-2*zeta*v - x\", got {text!r}")
    if not text.strip():
        raise ExpressionError("must be an expression, got an empty string")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"is longer than {MAX_LENGTH} characters")
    if "#" in text:
        # Inside YAML quotes a # is text, and Python's parser took it as a comment: "-x - 0.1*v # - x**3"
        # ran as -x - 0.1*v, the rest of the model dropped without a word.
        raise ExpressionError(f"holds a '#', which would silently end the expression there: a YAML comment "
                              f"goes after the closing quote: {text.strip()!r}")
    _refuse_non_ascii(text)
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as error:
        if "\n" in text.strip():  # a YAML literal block (|): Python ends the expression at the line's end
            raise ExpressionError(f"spans lines, which an expression may not: write it on one line, or as a "
                                  f"folded block (>-), whose lines YAML joins: {text.strip()!r}") from None
        where = f" at character {error.offset}" if error.offset else ""
        raise ExpressionError(f"is not a valid expression{where}: {text.strip()!r}") from None
    except (ValueError, RecursionError, MemoryError):
        raise ExpressionError("is not a valid expression (nested too deeply or holds a NUL character)") from None
    _check_as_written(tree, text.strip())
    _check(tree.body, frozenset(names), 0)
    return tree.body


def _check_as_written(tree, text):
    """Refuse a literal no double holds: 1e-400 is 0.0 to Python's parser, and a model with
    '1e-400*x' ran as '0.0*x'. (Names Python reads as others, Unicode's compatibility forms, are
    refused before parsing: _refuse_non_ascii.)"""
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value == 0.0:
            written = ast.get_source_segment(text, node)  # inf: _check says "too large"
            problem = written and beyond_double(written.replace("_", ""), node.value)
            if problem:
                raise ExpressionError(f"holds the number {clip(written)}, which {problem}")


# Typeset operators a pasted equation brings, and what they mean here.
_TYPESET_OPERATORS = {"\u2212": "-", "\u2013": "-", "\u00d7": "*", "\u22c5": "*", "\u00b7": "*", "\u2215": "/"}


class NonAsciiError(ExpressionError):
    """An expression holding a character outside ASCII."""


def _refuse_non_ascii(text):
    """Refuse any character outside ASCII, naming it. Python's parser folds identifiers by NFKC:
    'Ｆ' (fullwidth) and '𝑥' (mathematical italic) were silently read as the parameter F and the
    position x, so a model pasted from a typeset paper ran as another equation than the one
    shown. The language is ASCII (names, digits, operators), so nothing else can be meant."""
    for offset, character in enumerate(text.strip(), start=1):
        if character.isascii():
            continue
        name = unicodedata.name(character, "an unnamed character")
        folded = unicodedata.normalize("NFKC", character)
        if character in _TYPESET_OPERATORS:
            advice = f"write {_TYPESET_OPERATORS[character]!r} instead"
        elif folded != character and folded.isascii():
            advice = f"Python's parser would silently read it as {folded!r}: write that in ASCII"
        elif unicodedata.category(character).startswith("L"):
            advice = "write names in ASCII letters (zeta) and give their typeset look under model.symbols"
        else:
            advice = "write expressions in ASCII"
        raise NonAsciiError(f"holds {character!r} (U+{ord(character):04X} {name}) at character {offset}: "
                            f"{advice}: {text.strip()!r}")


def _constant(node, value):
    """``value`` (a constant part's, or None) if it is a finite real number; refused otherwise."""
    if value is None:
        return None
    with np.errstate(all="ignore"):
        value = float(value)
    if not math.isfinite(value):
        raise ExpressionError(f"has a constant part that is not a finite real number: {_token(node)} = {value} "
                              f"(in real arithmetic)")
    return value


def _token(node) -> str:
    try:
        text = ast.unparse(node)
    except Exception:  # noqa: BLE001 - only for the message
        text = type(node).__name__
    return clip(text)


def _check(node, names, depth):
    """Checks ``node`` and returns its value when it holds no name but pi (a constant part), else
    None. Constant parts are folded in doubles here, as numpy and the kernel would compute them:
    exact integers (sympy's) would let 2**10**10 run for ever and print 10**20 as an integer that
    numba cannot type, and 1/0 or sqrt(-1) would put inf or a complex number into the kernel."""
    if depth > MAX_DEPTH:
        # A sum of 61 terms is a chain of 60 operators: say so, or the message puzzles a flat sum.
        raise ExpressionError(f"is nested more than {MAX_DEPTH} deep (each operator of a chain such as "
                              f"a + b + c + ... is a level: group a long sum or product in parentheses)")
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"may hold numbers but not {_token(node)} (only numbers, names and operators)")
        try:
            value = float(node.value)
        except OverflowError:  # an integer literal beyond a double
            value = math.inf
        if not math.isfinite(value):
            raise ExpressionError(f"holds a number too large for a double: {_token(node)}")
        return value
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in names:
            return None
        if node.id in FUNCTIONS:
            raise ExpressionError(f"uses the function {node.id} without calling it: write {node.id}(...)")
        if node.id in STATE_NAMES:  # "unknown name 't'" puzzled: t is known, in the acceleration
            raise ExpressionError(f"depends on {node.id}, but it may depend on the parameters only (x, v and t "
                                  f"are the acceleration's)")
        known = ", ".join(sorted(names)) or "none"
        raise ExpressionError(f"refers to an unknown name {node.id!r} (known: {known}, pi)")
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left = _check(node.left, names, depth + 1)
        right = _check(node.right, names, depth + 1)
        # Any constant exponent, not only a literal one: x**-100, x**(2**100) and 2**10**10 too.
        if isinstance(node.op, ast.Pow) and right is not None and abs(right) > MAX_EXPONENT:
            raise ExpressionError(f"has a power beyond {MAX_EXPONENT}: {_token(node)}")
        return _constant(node, None if left is None or right is None else evaluate(node, {}))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        operand = _check(node.operand, names, depth + 1)
        return None if operand is None else (-operand if isinstance(node.op, ast.USub) else operand)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            raise ExpressionError(f"calls {_token(node.func)}, which is not one of the functions "
                                  f"{', '.join(FUNCTIONS)}")
        if node.keywords:
            raise ExpressionError(f"passes a keyword to {node.func.id}: {_token(node)}")
        if any(isinstance(arg, ast.Starred) for arg in node.args):  # counted as one: "1 argument(s), not 1"
            raise ExpressionError(f"unpacks an argument with * in {_token(node)}: write the arguments out")
        wanted = 2 if node.func.id in ("min", "max") else 1
        if len(node.args) != wanted:
            raise ExpressionError(f"calls {node.func.id} with {len(node.args)} argument(s), not {wanted}: "
                                  f"{_token(node)}")
        values = [_check(arg, names, depth + 1) for arg in node.args]
        return _constant(node, None if None in values else evaluate(node, {}))
    kind = {ast.Attribute: "an attribute", ast.Subscript: "a subscript", ast.Lambda: "a lambda",
            ast.Compare: "a comparison", ast.BoolOp: "a logical operator", ast.IfExp: "a conditional",
            ast.List: "a list", ast.Tuple: "a tuple", ast.Dict: "a mapping", ast.Set: "a set",
            ast.ListComp: "a comprehension", ast.GeneratorExp: "a comprehension",
            ast.DictComp: "a comprehension", ast.SetComp: "a comprehension", ast.JoinedStr: "a string",
            ast.NamedExpr: "an assignment", ast.Await: "an await", ast.Starred: "a starred argument"}
    what = next((word for cls, word in kind.items() if isinstance(node, cls)), "an operator")
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitXor):
        # x^2 is a square in Matlab, Maple and LaTeX: "the operator BitXor" told a researcher nothing
        raise ExpressionError(f"writes ^, which is not a power here: write ** for a power (x**2, not x^2): "
                              f"{_token(node)}")
    if isinstance(node, ast.BinOp):
        what = f"the operator {type(node.op).__name__}"
    raise ExpressionError(f"may not hold {what}: {_token(node)} (only numbers, names, + - * / ** and the "
                          f"functions {', '.join(FUNCTIONS)})")


def switch_count(tree) -> int:
    """How many surfaces the kinks and jumps of ``tree`` lie on (an upper bound: each distinct
    argument of abs and sign, and each pair of distinct arguments of min and max, nested calls of
    one merged as sympy merges them, that holds x, v or t; s and -s are one). Beyond MAX_SWITCHES
    the kernel located the first 52 and stepped across the rest unlocated, the method's order lost
    there, and nothing said so."""
    surfaces = set()

    def text(node):
        while isinstance(node, ast.UnaryOp):  # -s and +s: the surface of s
            node = node.operand
        return ast.unparse(node)

    def arguments(node, function):
        for argument in node.args:
            if isinstance(argument, ast.Call) and isinstance(argument.func, ast.Name) and argument.func.id == function:
                yield from arguments(argument, function)
            else:
                yield argument

    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in SWITCHES):
            continue
        every = {text(argument): names_in(argument) & set(STATE_NAMES) for argument in arguments(node, node.func.id)}
        if node.func.id in ("abs", "sign"):
            surfaces.update(argument for argument, moves in every.items() if moves)
        else:
            surfaces.update(frozenset((a, b)) for a in every for b in every if a < b and every[a] | every[b])
    return len(surfaces)


def names_in(tree) -> set[str]:
    """The names an expression refers to (pi and the functions left out)."""
    return {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)
            and node.id not in CONSTANTS and not _is_function(tree, node)}


def _is_function(tree, name_node):
    return any(isinstance(node, ast.Call) and node.func is name_node for node in ast.walk(tree))


def canonical(text) -> str:
    """The expression as Python writes its tree back: the same text for the same expression
    however it was spaced (cache keys, stored files)."""
    return ast.unparse(ast.parse(text.strip(), mode="eval").body)


_NUMPY_FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
                    "sqrt": np.sqrt, "abs": np.abs, "tanh": np.tanh, "sign": np.sign,
                    "min": np.minimum, "max": np.maximum}


def evaluate(tree, values):
    """The expression's value with numpy, names from ``values`` (scalars or arrays, broadcast).
    Invalid operations give NaN or inf (numpy's rules), never an exception."""
    with np.errstate(all="ignore"):
        return np.asarray(_evaluate(tree, values), dtype=np.float64)


def _evaluate(node, values):
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return CONSTANTS[node.id] if node.id in CONSTANTS else np.asarray(values[node.id], dtype=np.float64)
    if isinstance(node, ast.UnaryOp):
        operand = _evaluate(node.operand, values)
        return -operand if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.BinOp):
        left, right = _evaluate(node.left, values), _evaluate(node.right, values)
        op = type(node.op)
        if op is ast.Add:
            return np.add(left, right)
        if op is ast.Sub:
            return np.subtract(left, right)
        if op is ast.Mult:
            return np.multiply(left, right)
        if op is ast.Div:
            return np.divide(left, right)
        return np.power(np.asarray(left, dtype=np.float64), right)
    function = _NUMPY_FUNCTIONS[node.func.id]
    return function(*(_evaluate(arg, values) for arg in node.args))


def to_sympy(tree, symbols):
    """The expression as a sympy expression, names -> ``symbols[name]`` (sympy is imported here,
    only when a model is compiled)."""
    import sympy

    functions = {"sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "exp": sympy.exp, "log": sympy.log,
                 "sqrt": sympy.sqrt, "abs": sympy.Abs, "tanh": sympy.tanh, "sign": sympy.sign,
                 "min": sympy.Min, "max": sympy.Max}

    def convert(node):
        if isinstance(node, ast.Constant):
            value = node.value
            return sympy.Integer(value) if isinstance(value, int) else sympy.Float(repr(float(value)), 17)
        if isinstance(node, ast.Name):
            return sympy.pi if node.id == "pi" else symbols[node.id]
        if isinstance(node, ast.UnaryOp):
            operand = convert(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            left, right = convert(node.left), convert(node.right)
            op = type(node.op)
            if op is ast.Add:
                return left + right
            if op is ast.Sub:
                return left - right
            if op is ast.Mult:
                return left * right
            if op is ast.Div:
                return left / right
            return left ** right
        return functions[node.func.id](*(convert(arg) for arg in node.args))

    return convert(tree)
