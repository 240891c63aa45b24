"""Start and stop node graphs as separate processes: the launcher behind ``trial``, the manager and the tests.

A full ROS 2 install would use ``ros2 launch`` (see the launch files in ``launch/``); the PyPI wheels have no
``launch``, so this module starts the installed executables itself, each node in its own process (or a
trial graph's controllers all in one, ``CONTROLLER_PROCESSES``), all in one ROS domain, and stops them with
SIGINT, then SIGKILL for any that does not stop in time. Each process's output and its ROS log files
(``ROS_LOG_DIR``) go to the graph's log directory when it has one. Nothing here imports ``rclpy``. Every
process it starts dies with the process that started it, whatever kills that one
(``processes.die_with_parent``).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import yaml
from ament_index_python.packages import (
    PackageNotFoundError,
    get_package_prefix,
    get_package_share_directory,
)

from bt_controller.language import load_library
from evolution_manager.errors import GraphError
from evolution_manager.processes import die_with_parent
from swarm_ros.isolation import domain_environment
from swarm_ros.names import robot_namespaces
from swarm_ros.safe_paths import UnsafePathError, make_folder, open_no_follow
from swarm_sim.model import DEFAULT, load_layout
from swarm_sim.nodes.settings import RATE_RANGE, TIMINGS
from swarm_sim.tasks import resolve_task, world_parameters


def executable(package: str, name: str) -> Path:
    """The installed executable ``name`` of ``package`` (where ``ros2 run`` finds it)."""
    try:
        prefix = Path(get_package_prefix(package))
    except PackageNotFoundError:
        raise GraphError(f"package {package} is not installed: source the workspace (ws/env.sh)") from None
    path = prefix / "lib" / package / name
    if not os.access(path, os.X_OK):
        raise GraphError(f"package {package} has no executable {name} (looked for {path})")
    return path


def ros_arguments(
    *,
    namespace: str = "",
    node_name: str = "",
    parameters: Mapping[str, object] | None = None,
    params_files: Sequence[Path] = (),
    remaps: Mapping[str, str] | None = None,
) -> list[str]:
    """One node's ROS arguments, ``--ros-args ...``: its namespace and name, ``remaps`` (topic name -> the
    name it is remapped to), the parameter files (each overriding the ones before it) and ``parameters``
    (overriding them all)."""
    command = ["--ros-args"]
    if namespace:
        command += ["-r", f"__ns:={namespace}"]
    if node_name:
        command += ["-r", f"__node:={node_name}"]
    for topic, remapped in (remaps or {}).items():
        command += ["-r", f"{topic}:={remapped}"]
    for params_file in params_files:
        command += ["--params-file", str(params_file)]
    for key, value in (parameters or {}).items():
        command += ["-p", f"{key}:={parameter_text(value)}"]
    return command


class Graph:
    """A set of node processes in one ROS domain; a context manager that stops them all on exit."""

    def __init__(self, domain: int, log_dir: Path | None = None) -> None:
        self.domain = domain
        self.log_dir = log_dir
        self.processes: dict[str, subprocess.Popen] = {}
        self._logs: list[IO[str]] = []
        self._log_paths: dict[str, Path] = {}

    def __enter__(self) -> Graph:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def start(
        self,
        name: str,
        package: str,
        executable_name: str,
        *,
        namespace: str = "",
        node_name: str = "",
        parameters: dict[str, object] | None = None,
        params_files: Sequence[Path] = (),
        arguments: Sequence[str] = (),
        remaps: Mapping[str, str] | None = None,
    ) -> subprocess.Popen:
        """Start one node process, known in this graph as ``name``. Each parameter file overrides the ones
        before it; ``parameters`` override them all; ``remaps``: topic name -> the name it is remapped to."""
        ros_args = ros_arguments(
            namespace=namespace,
            node_name=node_name,
            parameters=parameters,
            params_files=params_files,
            remaps=remaps,
        )
        return self._spawn(name, [str(executable(package, executable_name)), *arguments, *ros_args])

    def start_nodes(
        self, name: str, package: str, executable_name: str, nodes: Sequence[Sequence[str]]
    ) -> subprocess.Popen:
        """Start one process holding several nodes (``footbot_controllers``), known in this graph as
        ``name``: each of ``nodes`` is one node's ROS arguments (:func:`ros_arguments`), given after a
        ``--node`` of its own."""
        command = [str(executable(package, executable_name))]
        for node in nodes:
            command += ["--node", *node]
        return self._spawn(name, command)

    def _spawn(self, name: str, command: list[str]) -> subprocess.Popen:
        if name in self.processes:
            raise GraphError(f"a process named {name} is already running")
        output: IO[str] | int = subprocess.DEVNULL
        env = domain_environment(self.domain)
        if self.log_dir is not None:
            log = self.log_dir / f"{name.replace('/', '_')}.log"
            try:  # a link planted at the folder, a log or ros/ (a shared run folder) is refused
                make_folder(self.log_dir / "ros", self.log_dir.parent)
                output = os.fdopen(open_no_follow(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), "w")
            except UnsafePathError as error:
                raise GraphError(str(error)) from None
            except OSError as error:
                raise GraphError(f"cannot write the node log {log}: {error.strerror or error}") from None
            self._log_paths[name] = log
            self._logs.append(output)
            env["ROS_LOG_DIR"] = str(self.log_dir / "ros")
        process = subprocess.Popen(
            command,
            env=env,
            stdout=output,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            preexec_fn=die_with_parent,
        )
        self.processes[name] = process
        return process

    def exited(self) -> list[str]:
        """The names of the processes that have exited (they stay known until :meth:`forget`)."""
        return [name for name, p in self.processes.items() if p.poll() is not None]

    def forget(self, name: str) -> None:
        """Forget an exited process (so that its name can be started again)."""
        process = self.processes.pop(name)
        process.wait()

    def check(self) -> None:
        """Raise ``GraphError`` naming every process that has exited, each with the last line of its log (a
        node that refuses its parameters says why in one line)."""
        dead = [
            f"{name} (exit code {p.returncode}{self._last_words(name)})"
            for name, p in self.processes.items()
            if p.poll() is not None
        ]
        if dead:
            where = f"; see the logs in {self.log_dir}" if self.log_dir else ""
            raise GraphError(f"node process(es) exited: {', '.join(dead)}{where}")

    def _last_words(self, name: str) -> str:
        """``: <the last line of the process's log>``, or nothing when it has no log or an empty one."""
        path = self._log_paths.get(name)
        try:
            lines = path.read_text(errors="replace").strip().splitlines() if path else []
        except OSError:
            return ""
        return f": {lines[-1].strip()}" if lines else ""

    def kill(self, name: str) -> None:
        """Kill one process with SIGKILL (for fault-injection tests) and forget it."""
        process = self.processes.pop(name)
        process.send_signal(signal.SIGKILL)
        process.wait()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop every process: SIGINT, then SIGKILL for those still running after ``timeout`` seconds."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in self.processes.values():
            try:
                process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        self.processes.clear()
        for log in self._logs:
            log.close()
        self._logs.clear()


def package_config(package: str) -> Path:
    """The installed parameter file of ``package`` (``share/<package>/config/<package>.yaml``)."""
    try:
        path = Path(get_package_share_directory(package)) / "config" / f"{package}.yaml"
    except PackageNotFoundError:
        raise GraphError(f"package {package} is not installed: source the workspace (ws/env.sh)") from None
    if not path.is_file():
        raise GraphError(f"package {package} has no parameter file (looked for {path})")
    return path


@dataclass(frozen=True)
class NodeSpec:
    """One node of a graph: what ``ros2 launch`` and :func:`start_trial_graph` both start."""

    name: str
    """The process's name in the graph (and its log file's)."""
    package: str
    executable: str
    namespace: str
    """Absolute namespace ("" for the root)."""
    parameters: dict[str, object] = field(default_factory=dict)
    """Parameters that override the parameter files."""
    remaps: dict[str, str] = field(default_factory=dict)
    """Topic remappings (name -> new name)."""


def parameter_text(value: object) -> str:
    """A parameter's value as ``-p NAME:=VALUE`` takes it (YAML): lists and tuples as ``[a, b]``, booleans as
    ``true``/``false``, text that YAML would read as a list or a mapping (a layout's JSON) quoted, anything
    else as its text."""
    if isinstance(value, (bool, list, tuple)):
        return json.dumps(list(value) if isinstance(value, tuple) else value)
    if isinstance(value, str) and _reads_as_collection(value):
        return json.dumps(value)  # a JSON string is a YAML double-quoted scalar
    return str(value)


def _reads_as_collection(text: str) -> bool:
    """Whether YAML would read ``text`` as a list or a mapping (or not at all) rather than a scalar."""
    try:
        return isinstance(yaml.safe_load(text), (list, dict))
    except yaml.YAMLError:
        return True


@dataclass(frozen=True)
class Bridge:
    """A trial graph's readings from the virtual-sensor bridge, over a link that loses a robot's pair of
    readings with probability ``loss`` or holds it back up to ``delay`` sensing periods, drawn from
    ``seed`` (``swarm_sim.nodes.virtual_sensors.Delivery``)."""

    loss: float = 0.0
    delay: int = 0
    seed: int = 0


def trial_graph_nodes(
    robots: int = DEFAULT.n_robots,
    namespace: str = "",
    tree: str | Sequence[str] = "",
    profile: str = "",
    conditions: Sequence[str] = (),
    clock: str = "/clock",
    library: str = "",
    world: Mapping[str, object] | None = None,
    timing: str = "lockstep",
    rate: float = 1.0,
    bridge: Bridge | None = None,
) -> list[NodeSpec]:
    """The nodes of a trial graph under ``namespace`` (e.g. ``/swarm_a``; the root by default): the simulator
    in ``<namespace>``, robot ``i``'s controller in ``<namespace>/footbot_<i>`` (its index taken from that
    namespace). ``tree`` is loaded into every controller when given (a sequence: robot ``i``'s controller
    loads ``tree[i]``, a heterogeneous swarm's trees); ``profile`` sets the simulator's model
    profile when given (else its parameter file's); ``conditions`` (``NAME=VALUE`` texts,
    ``swarm_sim.model.conditions``) change the simulator's world; ``clock``: the topic of the simulator's
    clock (``/clock``, at the root whatever the namespace, unless two graphs share a domain); ``library``: a
    primitive library file every controller reads (its ``library`` parameter); ``world``: the simulator's
    world parameters a task sets (``swarm_sim.tasks.world_parameters``; ``n_robots`` is ``robots``'s);
    ``timing``: ``lockstep`` (the default: the nodes' own defaults, bit-exact) or ``free`` (the simulator
    steps at ``rate`` times real time with each robot's latest answer; the controllers tick on their own
    timers in the graph's simulated time, ``timing:=free`` and ``use_sim_time:=true``); ``bridge`` (free
    timing only): the robots' readings come from the virtual-sensor bridge (``swarm_sim sensor_bridge``, in
    the graph's namespace, following its clock and each trial's ``trial_start``) over a link of the bridge's
    loss and delay, not from the simulator (``sensing:=external``)."""
    if robots < 1:
        raise GraphError(f"a trial graph needs at least one robot, got {robots}")
    if timing not in TIMINGS:
        raise GraphError(f"timing {timing!r}: expected one of {', '.join(TIMINGS)}")
    if not RATE_RANGE[0] <= rate <= RATE_RANGE[1]:
        raise GraphError(f"rate {rate}: expected a number in {RATE_RANGE[0]}..{RATE_RANGE[1]}")
    if bridge is not None and timing != "free":
        raise GraphError("the virtual-sensor bridge senses on its own clock: it needs timing free")
    prefix = namespace.rstrip("/")
    simulator: dict[str, object] = {**(world or {}), "n_robots": robots}
    if profile:
        simulator["profile"] = profile
    if conditions:
        simulator["conditions"] = " ".join(conditions)
    controller: dict[str, object] = {"library": library} if library else {}
    if timing == "free":
        simulator.update(timing="free", rate=float(rate))
        controller.update(timing="free", use_sim_time=True)
    trees = [tree] * robots if isinstance(tree, str) else list(tree)
    if len(trees) != robots:
        raise GraphError(f"{len(trees)} trees for {robots} robots: give one tree, or one per robot")
    # every node's /clock is the graph's: the simulator publishes it, a node with use_sim_time follows it
    remaps = {"/clock": clock} if clock != "/clock" else {}
    if bridge is not None:
        simulator["sensing"] = "external"
    nodes = [NodeSpec(f"{prefix}/simulator".lstrip("/"), "swarm_sim", "simulator", prefix, simulator, remaps)]
    if bridge is not None:
        link = {"loss": float(bridge.loss), "delay": bridge.delay, "seed": bridge.seed}
        nodes.append(
            NodeSpec(
                f"{prefix}/sensor_bridge".lstrip("/"),
                "swarm_sim",
                "sensor_bridge",
                prefix,
                {"robots": robots, "use_sim_time": True, "await_trial_start": True, **link},
                dict(remaps),
            )
        )
    for robot, own in zip(robot_namespaces(robots), trees, strict=True):
        nodes.append(
            NodeSpec(
                f"{prefix}/{robot}".lstrip("/"),
                "bt_controller",
                "footbot_controller",
                f"{prefix}/{robot}",
                {**controller, "tree": own} if own else dict(controller),
                dict(remaps),
            )
        )
    return nodes


LAUNCH_ARGUMENTS: dict[str, tuple[str, str]] = {
    "robots": ("", "number of footbots (default: the task's)"),
    "namespace": ("", "namespace of the whole graph, e.g. /swarm_a (default: the root)"),
    "tree": ("", "tree loaded into every controller"),
    "swarm": ("", "a swarm layout file: each controller loads its robot's tree"),
    "profile": ("", "model profile, paper or clean (default: the parameter file's)"),
    "task": ("", "a registered task or a task file (default: the parameter file's world)"),
    "library": ("", "a primitive library file every controller reads"),
    "clock": ("/clock", "the graph's clock topic; give each graph in a domain its own, e.g. /swarm_a/clock"),
    "commands": ("", "what the controllers publish: wheels, cmd_vel or both (default: wheels)"),
    "use_sim_time": ("false", "every node follows the graph's clock (true or false)"),
    "timing": (
        "lockstep",
        "lockstep (exact) or free: the simulator steps at rate times real time, the "
        "controllers tick on their own timers",
    ),
    "rate": ("1.0", "free timing: simulated seconds per second of wall time"),
    "params_file": ("", "a parameter file for every node, after the packages' own"),
}
"""The arguments of ``trial_graph.launch.py``: name -> (default, description). The options of ``trial`` that
shape the graph, and the controllers' ``commands`` and every node's ``use_sim_time``; the seed, trial and
bag are a goal's and a recorder's, not the graph's."""


def launch_graph_nodes(arguments: Mapping[str, str]) -> list[NodeSpec]:
    """The nodes ``trial_graph.launch.py`` starts for its ``arguments`` (texts, by the names of
    ``LAUNCH_ARGUMENTS``; a missing one takes its default), as ``trial`` would start them; ``GraphError``
    for a value that cannot be used. The parameter files are the launch file's."""
    unknown = sorted(set(arguments) - set(LAUNCH_ARGUMENTS))
    if unknown:
        raise GraphError(
            f"unknown launch arguments {', '.join(unknown)}; known: {', '.join(LAUNCH_ARGUMENTS)}"
        )
    value = {name: arguments.get(name, default) for name, (default, _) in LAUNCH_ARGUMENTS.items()}
    if value["use_sim_time"] not in ("true", "false"):
        raise GraphError(f"use_sim_time:={value['use_sim_time']}: expected true or false")
    try:
        rate = float(value["rate"])
    except ValueError:
        raise GraphError(f"rate:={value['rate']}: expected a number") from None
    try:
        task = resolve_task(value["task"]) if value["task"] else None
        robots = int(value["robots"]) if value["robots"] else task.robots.count if task else DEFAULT.n_robots
        library = load_library(value["library"]) if value["library"] else None
        tree: str | Sequence[str] = (
            load_layout(value["swarm"], robots, library).trees if value["swarm"] else value["tree"]
        )
    except (ValueError, OSError) as error:
        raise GraphError(f"launch arguments: {error}") from None
    nodes = trial_graph_nodes(
        robots,
        value["namespace"],
        tree=tree,
        profile=value["profile"],
        clock=value["clock"],
        library=value["library"],
        world=world_parameters(task.config(value["profile"] or None)) if task else None,
        timing=value["timing"],
        rate=rate,
    )
    sim_time = {"use_sim_time": True} if value["use_sim_time"] == "true" else {}
    commands = {"commands": value["commands"]} if value["commands"] else {}
    for spec in nodes:
        spec.parameters.update(sim_time)
        if spec.executable == "footbot_controller":
            spec.parameters.update(commands)
    return nodes


CONTROLLER_PROCESSES = ("one", "per-robot")
"""How a started trial graph lays its controllers out in processes: ``one`` process holding every robot's
controller node (``bt_controller footbot_controllers``, as a ROS 2 component container holds nodes: about
1 s of CPU to start nine, against about 1 s each as processes of their own), or one process ``per-robot``
(``footbot_controller``, as on robots, each with a computer of its own). The nodes, their names, topics,
services and results are the same either way."""


def start_trial_graph(
    graph: Graph,
    robots: int = DEFAULT.n_robots,
    conditions: Sequence[str] = (),
    *,
    namespace: str = "",
    params_file: Path | None = None,
    profile: str = "",
    clock: str = "/clock",
    library: str = "",
    world: Mapping[str, object] | None = None,
    timing: str = "lockstep",
    rate: float = 1.0,
    bridge: Bridge | None = None,
    controller_processes: str = "one",
) -> None:
    """Start the nodes of ``trial_graph_nodes(robots, namespace, profile=profile, conditions=conditions,
    clock=clock, library=library, world=world, timing=timing, rate=rate)``, the controllers in processes as
    ``controller_processes`` says (``CONTROLLER_PROCESSES``; the process holding them all is named
    ``<namespace>/controllers`` in the graph), every other node in a process of its own, each with its
    package's parameter file and then ``params_file`` (every node's); ``robots`` overrides ``n_robots``,
    ``profile`` (when given) the simulator's model profile. The simulator, a managed node, is started
    unconfigured (``autostart:=false``): the caller drives it through configure and activate
    (``TrialRunner.activate``)."""
    if controller_processes not in CONTROLLER_PROCESSES:
        expected = ", ".join(CONTROLLER_PROCESSES)
        raise GraphError(f"controller processes {controller_processes!r}: expected one of {expected}")
    nodes = trial_graph_nodes(
        robots,
        namespace,
        profile=profile,
        conditions=conditions,
        clock=clock,
        library=library,
        world=world,
        timing=timing,
        rate=rate,
        bridge=bridge,
    )
    shared = controller_processes == "one"
    held: list[list[str]] = []
    for spec in nodes:
        files = [package_config(spec.package), *([params_file] if params_file is not None else [])]
        managed = {"autostart": "false"} if spec.executable == "simulator" else {}
        parameters = {**spec.parameters, **managed}
        if shared and spec.executable == "footbot_controller":
            held.append(
                ros_arguments(
                    namespace=spec.namespace, parameters=parameters, params_files=files, remaps=spec.remaps
                )
            )
            continue
        graph.start(
            spec.name,
            spec.package,
            spec.executable,
            namespace=spec.namespace,
            parameters=parameters,
            params_files=files,
            remaps=spec.remaps,
        )
    if held:
        name = f"{namespace.rstrip('/')}/controllers".lstrip("/")
        graph.start_nodes(name, "bt_controller", "footbot_controllers", held)
