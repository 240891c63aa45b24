"""Simplification: a smaller tree that drives every robot's wheels identically, tick for tick, always.

``simplify(tree)`` rewrites a tree until no rule below applies. The result is *observationally equivalent*
to the original for the world: on every blackboard trace, with the same stream key, it sets the same motors
after every tick, hence the same trajectories, fitness, movement and rotation. Only the count of condition
ticks (conditionality) may change. It is sound under both readings of the model this project has had:

- motors = the action started by the tick (stop when the root does not return running), and
- motors = the last action ticked in the tick, on its running or its success tick (stop when none), with a
  probabilistic node that keeps a current child between ticks (child 0 first, or drawn first), redrawn
  whenever the child finishes (the ``paper`` and ``clean`` profiles).

Three facts about the memory semantics carry every proof below (``semantics`` module docstring):

1. *Only the running path has memory.* A sequence or selector clears its memory when it returns success or
   failure, an action is "not running" after its success tick, and a child that returns running is resumed by
   its parent at the next tick of the parent, which itself returned running, up to the root. So between ticks
   every sequence, selector and action off the root's running path is in its initial state. (A probabilistic
   node may keep a current child off the path; no rule merges or copies one, except rule 6 which needs
   prob-free children; a rule may move one, see "Draw keys".)
2. *A resumed node knows nothing of the blackboard.* A node ticked because its parent resumed at it follows
   no condition evaluated in the same tick; a node entered afresh follows its earlier siblings in the same
   tick (same blackboard), so what they established still holds ("knowledge", below).
3. *The root's success and failure look the same to the world.* Both clear the memory on the path and neither
   sets motors; so do a blind node's (the root; the last child of a blind sequence or selector; any child of
   a blind probabilistic node).

What each subtree shows its parent per tick is (status, last action ticked in it); under the first reading
the started action is that action when the status is running and none otherwise, so keeping (status, last
action) keeps both readings. Rules keep that pair exactly, except at blind positions, where success and
failure may swap.

Draw keys. A probabilistic node picks its children with ``choose(derive(key, tick), k, n_children)``
(``bt_controller.draws``), where ``k`` is its draw key (``tree.draw_key_at``: its own ``prob@k``, else its
pre-order index): nothing else about its place in the tree enters its picks, and its memory is its own. So a
rewrite may move a probabilistic node anywhere, as long as the node keeps its key, its number of children and
their order, and is never copied or merged with another (no rule does either). The simplifier carries every
node's original key along and writes ``prob@k`` where the node's new pre-order index is not ``k`` (plain
``prob`` where it is), so the simplified tree makes exactly the original's picks. The keys of the result are
the original's keys, so it shares a key between two nodes only where the original did. With
``keep_positions=True`` it makes only the rewrites that leave every surviving probabilistic node at its
pre-order index (the simplifier before draw keys existed; its result needs no key the original lacked).

The rules (each a rewrite of one subtree ``n``; its proof in a comment at the rule in ``_rewrites``):

1. *dead children*: a child of a sequence (selector) that is never entered afresh goes: it is never ticked.
2. *flatten*: ``seq(a, seq(b, c), d)`` is ``seq(a, b, c, d)`` (at most 4 children): both remember the same
   running child and finish alike.
3. *neutral condition*: an action-free child that always succeeds in a sequence (fails in a selector) goes:
   it only hands control on in the same tick.
4. *blind tail*: the action-free last child of a composite at a blind position goes: it only chooses between
   success and failure, which look alike there (fact 3).
5. *blind condition subtree*: an action-free composite at a blind position becomes its first condition: it
   shows the world nothing.
6. *identical choices*: ``prob(T, T, ...)`` with every child the same probabilistic-free ``T`` becomes ``T``:
   whichever is picked starts in the same state and behaves as ``T``.
7. *success of a child that never fails*: ``success(X)`` becomes ``X`` when ``X`` never returns failure: the
   decorator then passes every status on unchanged, and it has no memory of its own.
8. *blind success*: ``success(X)`` at a blind position becomes ``X``: it only turns failure into success,
   which look alike there (fact 3).

The success decorator (``success(X)``: success where ``X`` failed, else ``X``'s status; no memory of its own)
keeps the three facts: it remembers nothing off the running path (fact 1), it passes a resumption straight
to its child (fact 2), and it clears nothing and sets no motors when it finishes. Its child is always at a
blind position: its success and its failure both become the decorator's success, with the same (cleared)
memory and motors, so rules 4, 5 and 8 apply inside it.

A composite left with one child becomes that child (same statuses, same memory). Every rule keeps what each
subtree shows its parent on every tick, so it is sound wherever the subtree sits; the knowledge and blindness
it relies on are facts about every run of the tree, which other rewrites keep (each keeps statuses), so rules
can be applied one after the other until none applies. All passes are iterative (no recursion, whatever the
depth). After each rewrite only the path above it and the subtrees whose knowledge it changed are analysed
again (``_analyse``), which on evolved trees is a small part of them; but a chain collapsing level by level
is analysed almost whole after each of its rewrites, so the work can grow with the square of the size: trees
of more than ``MAX_SIMPLIFY_NODES`` nodes are refused (TreeLimitError; such a chain at that size takes 10-60 s
on one core, depending on the machine, a random tree of that size a few seconds).

Blackboard facts (``WORLD_FACTS``, ``WORLD_IMPLICATIONS``) hold in every profile: the two regions are
disjoint (r < 500 mm against r >= 1000 mm), a direction is left or right but not both
(``perception.is_left``/``is_right`` of one bearing; with no robot heard, robot_left is true under ``paper``
and both are false under ``clean``: never both), inside a region there is no direction to it (the raw
estimate is 0, no source: ``perception.estimate``), and got_food is the carrying flag after the step's
delivery check (``perception.carry``): on food it is set, in the nest it is clear. A tick reads the ground
and the flag of the same sensing step (no tick falls on a trial's unsensed first step).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from bt_controller.errors import TreeLimitError
from bt_controller.language.tree import MAX_NODES, Action, Composite, Condition, Node, draw_key_at
from bt_controller.language.vocabulary import CONDITIONS

S, F, R = "S", "F", "R"

MAX_SIMPLIFY_NODES = 2 * MAX_NODES
"""Largest tree ``simplify`` takes (twice the parser's default limit; module docstring)."""

Literal = tuple[int, bool]
"""(condition index, value)."""

Knowledge = frozenset[Literal] | None
"""Literals true whenever a node is ticked afresh; None: the node is never ticked afresh (dead)."""

_C = {name: i for i, name in enumerate(CONDITIONS)}

WORLD_FACTS: tuple[tuple[str, str], ...] = (
    ("in_nest", "on_food"),
    ("food_left", "food_right"),
    ("nest_left", "nest_right"),
    ("robot_left", "robot_right"),
    ("in_nest", "nest_left"),
    ("in_nest", "nest_right"),
    ("on_food", "food_left"),
    ("on_food", "food_right"),
    ("in_nest", "got_food"),
)
"""Pairs of conditions never true together on any blackboard, in either profile (module docstring)."""

WORLD_IMPLICATIONS: tuple[tuple[str, str], ...] = (("on_food", "got_food"),)
"""Pairs (a, b): on every blackboard, in either profile, b is true whenever a is (module docstring)."""


@dataclass(eq=False)
class _N:
    """A node under rewriting: ``orig`` is its pre-order index in the original tree and ``draw`` the draw key
    of a probabilistic node (kept through every rewrite; -1 for other nodes)."""

    kind: str  # "seq", "sel", "prob", "success", "cond" or "act"
    name: str
    children: list[_N]
    orig: int
    draw: int = -1
    # analysis, recomputed after every rewrite
    status: frozenset[str] = frozenset()
    pure: bool = True  # ticks no action
    has_prob: bool = False
    fresh: Knowledge = None
    blind: bool = False
    post_s: frozenset[Literal] = frozenset()
    post_f: frozenset[Literal] = frozenset()
    size: int = 1
    shape: int = 0  # equal for equal subtrees (interned structure)
    parent: _N | None = None
    slot: int = 0  # index among the parent's children
    seen: tuple[Knowledge, bool] | None = None  # what its last analysis was given: (knowledge, blind)
    # its rewrites (``_rewrites``), and whether its subtree has none: made with each analysis of the node
    rewrites: Sequence[tuple[int, str, _N]] = ()
    quiet: bool = False


def _from_node(tree: Node) -> _N:
    nodes = list(tree.preorder())
    out = []
    for index, node in enumerate(nodes):
        if isinstance(node, Composite):
            draw = draw_key_at(node, index) if node.kind == "prob" else -1
            out.append(_N(node.kind, node.kind, [], index, draw))
        elif isinstance(node, Condition):
            out.append(_N("cond", node.name, [], index))
        else:
            assert isinstance(node, Action)
            out.append(_N("act", node.name, [], index))
    for index, node in enumerate(nodes):
        if isinstance(node, Composite):
            child = index + 1  # children follow their parent in pre-order, each after the previous subtree
            for sibling in node.children:
                out[index].children.append(out[child])
                child += sibling.size
    return out[0]


def _to_node(root: _N) -> Node:
    """The tree of ``root``; a probabilistic node names its draw key where its pre-order index differs."""
    order = _walk(root)  # pre-order: a node's index is its new pre-order index
    position = {id(n): i for i, n in enumerate(order)}
    built: dict[int, Node] = {}
    for n in reversed(order):  # children before parents
        node: Node
        if n.kind == "cond":
            node = Condition(n.name)
        elif n.kind == "act":
            node = Action(n.name)
        else:
            key = n.draw if n.kind == "prob" and n.draw != position[id(n)] else None
            node = Composite(n.kind, tuple(built.pop(id(c)) for c in n.children), key)
        built[id(n)] = node
    return built[id(root)]


class _Facts:
    def __init__(
        self, pairs: tuple[tuple[str, str], ...], implications: tuple[tuple[str, str], ...] = ()
    ) -> None:
        self.excludes: dict[int, set[int]] = {}
        for a, b in pairs:
            self.excludes.setdefault(_C[a], set()).add(_C[b])
            self.excludes.setdefault(_C[b], set()).add(_C[a])
        self.implies: dict[int, set[int]] = {}  # a true makes these true
        self.implied_by: dict[int, set[int]] = {}  # a false makes these false
        for a, b in implications:
            self.implies.setdefault(_C[a], set()).add(_C[b])
            self.implied_by.setdefault(_C[b], set()).add(_C[a])
        self._closed: dict[frozenset[Literal], frozenset[Literal]] = {}

    def close(self, known: frozenset[Literal]) -> frozenset[Literal]:
        """Add what the facts imply, until nothing more follows: a true condition makes every condition it
        excludes false and every condition it implies true; a false one makes every condition implying it
        false."""
        closed = self._closed.get(known)
        if closed is None:
            closed = self._closed[known] = self._close(known)
        return closed

    def _close(self, known: frozenset[Literal]) -> frozenset[Literal]:
        while True:
            extra: set[Literal] = set()
            for c, v in known:
                if v:
                    extra.update((other, False) for other in self.excludes.get(c, ()))
                    extra.update((other, True) for other in self.implies.get(c, ()))
                else:
                    extra.update((other, False) for other in self.implied_by.get(c, ()))
            if extra <= known:
                return known
            known = known | extra


def _join(a: Knowledge, b: frozenset[Literal]) -> Knowledge:
    return None if a is None else a | b


@dataclass(eq=False)
class _Visit:
    """A composite being analysed: its next child, the children accounted for, and (sequence, selector) the
    knowledge for its next child and the statuses gathered so far."""

    n: _N
    next: int = 0
    done: int = 0
    knowledge: Knowledge = None
    status: frozenset[str] = frozenset()


def _analyse(root: _N, facts: _Facts, shapes: dict[tuple, int]) -> list[_N]:
    """Fill in every node's statuses, purity, knowledge, blindness, post-conditions, size, shape and parent;
    one iterative pass (pre-order on the way down, children before parents on the way up). ``shapes`` maps a
    subtree's structure to a small integer, equal for equal subtrees; keep it from one analysis to the next.

    A subtree given the same knowledge and blindness as at its last analysis keeps that analysis: what a node
    shows depends on nothing else, a subtree's nodes are never changed (a rewrite builds new nodes on the path
    above it), and every node stands once in the tree. So after a rewrite only the path above it and the
    subtrees whose knowledge it changed are analysed again, not the whole tree. Returns the nodes analysed
    anew, children before parents."""
    anew: list[_N] = []

    def enter(n: _N, fresh: Knowledge, blind: bool, parent: _N | None, slot: int) -> _Visit | None:
        n.parent, n.slot = parent, slot
        if n.seen is not None and n.seen[1] == blind and n.seen[0] == fresh:
            return None
        n.seen = (fresh, blind)
        n.fresh = None if fresh is None else facts.close(fresh)
        n.blind = blind
        if n.kind == "cond":
            c = _C[n.name]
            n.post_s, n.post_f = frozenset({(c, True)}), frozenset({(c, False)})
            n.pure, n.has_prob, n.size = True, False, 1
            n.shape = shapes.setdefault(("cond", n.name), len(shapes))
            if n.fresh is None:
                n.status = frozenset()
            elif (c, True) in n.fresh:
                n.status = frozenset({S})
            elif (c, False) in n.fresh:
                n.status = frozenset({F})
            else:
                n.status = frozenset({S, F})
            anew.append(n)
            return None
        if n.kind == "act":
            # Entered afresh it starts and runs; resumed, it succeeds.
            n.status = frozenset() if n.fresh is None else frozenset({R, S})
            n.pure, n.has_prob, n.size = n.fresh is None, False, 1
            n.shape = shapes.setdefault(("act", n.name), len(shapes))
            n.post_s = n.post_f = frozenset()
            anew.append(n)
            return None
        return _Visit(n, knowledge=n.fresh)

    def finish(visit: _Visit) -> None:
        n = visit.n
        kids = n.children
        if n.kind == "success":
            child = kids[0]
            n.status = (frozenset({S}) if child.status & {S, F} else frozenset()) | (child.status & {R})
            outcomes = ((child.post_s, S), (child.post_f, F))
            n.post_s = _meet([post for post, status in outcomes if status in child.status])
            n.post_f = frozenset()
        elif n.kind == "prob":
            n.status = frozenset().union(*(c.status for c in kids))
            n.post_s = _meet([c.post_s for c in kids if S in c.status])
            n.post_f = _meet([c.post_f for c in kids if F in c.status])
        else:
            go_on, stop = (S, F) if n.kind == "seq" else (F, S)
            status = visit.status
            if go_on in kids[-1].status:
                status = status | {go_on}
            n.status = status
            chain = _chain([c.post_s if go_on == S else c.post_f for c in kids], kids)
            ends = _meet([c.post_f if go_on == S else c.post_s for c in kids if stop in c.status])
            n.post_s, n.post_f = (chain, ends) if go_on == S else (ends, chain)
        n.pure = all(c.pure for c in kids)
        n.has_prob = n.kind == "prob" or any(c.has_prob for c in kids)
        n.size = 1 + sum(c.size for c in kids)
        n.shape = shapes.setdefault((n.kind, n.draw, *(c.shape for c in kids)), len(shapes))
        anew.append(n)

    top = enter(root, frozenset(), True, None, 0)
    stack = [top] if top is not None else []
    while stack:
        visit = stack[-1]
        n = visit.n
        kids = n.children
        if visit.done < visit.next and n.kind in ("seq", "sel"):
            # The child just analysed decides what the next one knows (sequence, selector).
            child = kids[visit.done]
            visit.done = visit.next
            go_on, stop = (S, F) if n.kind == "seq" else (F, S)
            if child.fresh is not None:
                visit.status = visit.status | (child.status & {stop, R})
            # The next child is entered afresh only after this one returned ``go_on`` in the same tick;
            # this one was then afresh (knowledge holds) or resumed (nothing known, fact 2).
            if go_on not in child.status:
                visit.knowledge = None
            else:
                before = child.fresh if R not in child.status else frozenset()
                visit.knowledge = _join(before, child.post_s if go_on == S else child.post_f)
        if visit.next < len(kids):
            i = visit.next
            visit.next += 1
            if n.kind == "prob":
                fresh, blind = n.fresh, n.blind
            elif n.kind == "success":
                fresh, blind = n.fresh, True  # its success and failure both become success
            else:
                fresh, blind = visit.knowledge, n.blind and i == len(kids) - 1
            inner = enter(kids[i], fresh, blind, n, i)
            if inner is not None:
                stack.append(inner)
            continue
        finish(visit)
        stack.pop()
    return anew


def _meet(sets: list[frozenset[Literal]]) -> frozenset[Literal]:
    if not sets:
        return frozenset()
    out = sets[0]
    for s in sets[1:]:
        out = out & s
    return out


def _chain(posts: list[frozenset[Literal]], kids: list[_N]) -> frozenset[Literal]:
    """What holds when every child returned ``go_on``: the last child's post-condition, and each earlier
    one's as long as the later ones cannot run (then they were all entered in the same tick)."""
    out = posts[-1]
    for i in range(len(kids) - 1, 0, -1):
        if R in kids[i].status:
            break
        out = out | posts[i - 1]
    return out


# ------------------------------------------------------------------------------------------------- rules


def _rewrites(n: _N) -> list[tuple[int, str, _N]]:
    """Candidate rewrites of the subtree ``n``: (priority, rule, replacement); lower priority first."""
    out: list[tuple[int, str, _N]] = []
    if n.kind in ("cond", "act") or n.fresh is None:  # a dead subtree goes whole (rule 1 at its parent)
        return out
    kids = n.children
    if n.kind in ("seq", "sel"):
        # Rule 1 (dead children). A sequence enters child i+1 only after child i returned success in the
        # same tick, or resumes at it after it ran: both need it to have been entered once. A child never
        # entered afresh is never ticked at all: its memory, motors and draws never matter (selector:
        # the same with failure).
        live = [c for c in kids if c.fresh is not None]
        if len(live) < len(kids):
            out.append((0, "dead children", _rebuild(n, live)))
        # Rule 3 (neutral conditions). A child that ticks no action and always succeeds (sequence) or
        # always fails (selector) when ticked only passes control to the next child in the same tick, or
        # ends the composite with the status its last child would have given: removing it changes
        # neither statuses nor motors (its draws, if any, are its own).
        neutral = S if n.kind == "seq" else F
        keep = [c for c in kids if not (c.pure and c.status == frozenset({neutral}))]
        if len(keep) < len(kids):
            out.append((2, "neutral condition", _rebuild(n, keep or kids[:1])))
        # Rule 4 (blind tail). At a blind position the last child's success and failure look the same to
        # the world (fact 3); a last child that ticks no action then only decides between them.
        if n.blind and len(kids) > 1 and kids[-1].pure:
            out.append((2, "blind tail", _rebuild(n, kids[:-1])))
        # Rule 2 (flattening). seq(a, seq(b, c), d) == seq(a, b, c, d): the inner sequence resumes where its
        # running child is and the outer one resumes at the inner one, so both remember the same child;
        # a failure inside clears both; success of the inner one moves on in both. Only up to 4 children.
        for i, c in enumerate(kids):
            if c.kind == n.kind and len(kids) - 1 + len(c.children) <= 4:
                flat = kids[:i] + c.children + kids[i + 1 :]
                out.append((3, "flatten", _rebuild(n, flat)))
    # Rule 6 (identical choices). prob(T, T, ...) with every child the same prob-free subtree: whichever
    # is picked, it is in its initial state when entered (fact 1: a prob-free subtree returns to it when
    # it finishes), so each behaves as T would; the picks no longer matter.
    if n.kind == "prob" and not any(c.has_prob for c in kids) and len({c.shape for c in kids}) == 1:
        out.append((1, "identical choices", kids[0]))
    if n.kind == "success":
        child = kids[0]
        # Rule 7 (success of a child that never fails). The decorator only turns failure into success and
        # has no memory of its own: over a child that never fails it passes every status on unchanged.
        if F not in child.status:
            out.append((1, "success never needed", child))
        # Rule 8 (blind success). At a blind position failure and success look alike (fact 3), so turning
        # one into the other shows the world nothing.
        elif n.blind:
            out.append((1, "blind success", child))
    # Rule 5 (blind condition-only subtree). A composite that ticks no action at a blind position shows the
    # world nothing (fact 3 and no motors): its first condition does the same.
    if n.blind and n.pure and n.fresh is not None:
        first = n
        while first.children:
            first = first.children[0]
        out.append((1, "blind condition subtree", first))
    return out


def _rebuild(n: _N, children: list[_N]) -> _N:
    """``n`` with ``children``; a composite of one child is that child (same statuses, same memory)."""
    if len(children) == 1:
        return children[0]
    return _N(n.kind, n.name, children, n.orig, n.draw)


def _replace(root: _N, target: _N, replacement: _N) -> _N:
    """The tree ``root`` with ``target`` replaced: new nodes on the path up from ``target`` (parents as the
    last analysis found them), every other subtree shared."""
    node, new = target, replacement
    while node.parent is not None:
        parent = node.parent
        children = list(parent.children)
        children[node.slot] = new
        node, new = parent, _N(parent.kind, parent.name, children, parent.orig, parent.draw)
    assert node is root
    return new


def _analyse_rewrites(root: _N, facts: _Facts, shapes: dict[tuple, int], kept_whole: frozenset[int]) -> None:
    """Analyse the tree (``_analyse``) and find the rewrites of each node analysed anew (none for the nodes
    of ``kept_whole``) and whether its subtree has any."""
    for n in _analyse(root, facts, shapes):  # children before parents
        n.rewrites = [] if n.orig in kept_whole else _rewrites(n)
        n.quiet = not n.rewrites and all(c.quiet for c in n.children)


def _candidates(root: _N) -> list[tuple[int, int, str, _N, _N]]:
    """Every rewrite in the tree as (priority, minus the node's pre-order index, rule, node, replacement): the
    order to try them in (later positions first: they shifted fewer probabilistic nodes when positions
    mattered). Subtrees without a rewrite are passed over."""
    out: list[tuple[int, int, str, _N, _N]] = []
    stack = [(root, 0)]
    while stack:
        n, position = stack.pop()
        if n.quiet:
            continue
        out.extend((priority, -position, rule, n, replacement) for priority, rule, replacement in n.rewrites)
        child_position = position + 1
        for child in n.children:
            stack.append((child, child_position))
            child_position += child.size
    return out


def _keeps_positions(root: _N) -> bool:
    """Every probabilistic node sits at its original pre-order index."""
    return all(n.kind != "prob" or n.orig == i for i, n in enumerate(_walk(root)))


def _walk(root: _N) -> list[_N]:
    """The nodes in pre-order."""
    out, stack = [], [root]
    while stack:
        n = stack.pop()
        out.append(n)
        stack.extend(reversed(n.children))
    return out


def _kept_whole(tree: Node, whole: Callable[[Node], bool] | None) -> frozenset[int]:
    """The original pre-order indices of the nodes of every subtree of ``tree`` that ``whole`` names, and of
    the nodes inside them: no rule rewrites them (a rule above may still drop such a subtree as a whole)."""
    if whole is None:
        return frozenset()
    kept: set[int] = set()
    for index, node in enumerate(tree.preorder()):
        if index not in kept and whole(node):
            kept.update(range(index, index + node.size))
    return frozenset(kept)


@dataclass(frozen=True)
class Simplified:
    """A simplification: the tree, and the rules applied in order."""

    tree: Node
    rules: tuple[str, ...]


def simplify_with_rules(
    tree: Node,
    facts: tuple[tuple[str, str], ...] = WORLD_FACTS,
    *,
    keep_positions: bool = False,
    implications: tuple[tuple[str, str], ...] | None = None,
    whole: Callable[[Node], bool] | None = None,
) -> Simplified:
    """Simplify ``tree``; also say which rules were applied (see ``simplify``)."""
    if tree.size > MAX_SIMPLIFY_NODES:
        raise TreeLimitError(f"tree has {tree.size} nodes; simplify takes at most {MAX_SIMPLIFY_NODES}")
    if implications is None:
        implications = WORLD_IMPLICATIONS if facts == WORLD_FACTS else ()
    known = _Facts(facts, implications)
    root = _from_node(tree)
    kept_whole = _kept_whole(tree, whole)
    shapes: dict[tuple, int] = {}
    applied: list[str] = []
    while True:
        _analyse_rewrites(root, known, shapes, kept_whole)
        candidates = _candidates(root)
        candidates.sort(key=lambda c: (c[0], c[1]))
        for _, _, rule, target, replacement in candidates:
            new_root = _replace(root, target, replacement)
            if not keep_positions or _keeps_positions(new_root):
                root = new_root
                applied.append(rule)
                break
        else:
            return Simplified(_to_node(root), tuple(applied))


def simplify(
    tree: Node,
    facts: tuple[tuple[str, str], ...] = WORLD_FACTS,
    *,
    keep_positions: bool = False,
    implications: tuple[tuple[str, str], ...] | None = None,
    whole: Callable[[Node], bool] | None = None,
) -> Node:
    """The simplest tree this module's rules reach from ``tree``: same motors on every tick of every
    blackboard trace, same probabilistic picks (each probabilistic node keeps its draw key, written
    ``prob@k`` where its pre-order index changed; module docstring), never larger. ``facts``: pairs of
    conditions never true together (``WORLD_FACTS``; pass ``()`` to assume nothing about blackboards);
    ``implications``: pairs (a, b) with b true whenever a is (default: ``WORLD_IMPLICATIONS`` with the world's
    facts, none with others). ``keep_positions``: make only rewrites that leave every probabilistic node at
    its pre-order index (no key is then added; the simplifier before draw keys). ``whole``: subtrees to keep
    as they are, rewritten neither inside nor at their root (a library's primitives, so that they can still
    be named: ``Library.is_copy``). TreeLimitError beyond ``MAX_SIMPLIFY_NODES``."""
    return simplify_with_rules(
        tree, facts, keep_positions=keep_positions, implications=implications, whole=whole
    ).tree


def simplify_if_small(tree: Node, whole: Callable[[Node], bool] | None = None) -> Node:
    """``simplify(tree)``, or ``tree`` itself when it has more than ``MAX_SIMPLIFY_NODES`` nodes: a tree that
    names primitives may expand beyond what ``simplify`` takes (``tree.parse`` limits the tree as written);
    for what needs a simplified form of any tree (clone keys, the trees shown to people)."""
    return tree if tree.size > MAX_SIMPLIFY_NODES else simplify(tree, whole=whole)
