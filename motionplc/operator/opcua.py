"""The machine's OPC UA server (asyncua): in the operator process (:meth:`OpcUaServer.serve`
in its event loop, :mod:`motionplc.operator.server`), or in a thread of its own with its own
event loop (:meth:`OpcUaServer.start`; the former design, kept for comparisons).

The address space follows OPC 40010-1 (OPC UA for Robotics) in its structure and names and
OPC 30000 (PLCopen / IEC 61131-3) for the tasks; see ``docs/operator.md`` for the mapping and
where it differs. The server never touches the live runtime objects: it reads the last
:class:`~motionplc.operator.desk.Snapshot` the cycle published and hands operator methods to
the cycle as :class:`~motionplc.operator.desk.Request` objects (:class:`OperatorDesk`).

Rights (the security matrix of ``docs/operator.md``):

* anonymous sessions (when ``anonymous``): read, browse, subscribe; a method call or a write
  is refused with ``BadUserAccessDenied``;
* a user of ``users`` (password checked against its scrypt hash): the same plus the methods,
  on a Sign or SignAndEncrypt channel only (on a None channel a user reads like anonymous);
* a wrong password or an unknown user: the session is not activated
  (``BadUserAccessDenied``).

Every method call is logged (logger ``motionplc.operator``) with the user, and kept in
:attr:`OperatorDesk.audit`.
"""

from __future__ import annotations

import asyncio
import contextvars
import hashlib
import logging
import socket
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from motionplc.blocks.enums import AxisState, ErrorID, GroupState
from motionplc.operator.desk import (
    AXIS_METHODS,
    GROUP_METHODS,
    PROGRAM_METHODS,
    OperatorDesk,
    Request,
    Snapshot,
    of_kind,
)
from motionplc.operator.settings import OpcUaSettings, check_password

__all__ = ["NAMESPACE", "OpcUaServer", "OpcUaStartError", "eu_information"]

LOG = logging.getLogger("motionplc.operator")
NAMESPACE = "urn:motionplc:machine"
METHOD_TIMEOUT = 5.0  # [s] a request the cycle did not take by then: BadTimeout

# the caller of the request being processed (set by the permission check of its message)
_CALLER: contextvars.ContextVar[tuple[str | None, int]] = contextvars.ContextVar(
    "motionplc_opcua_caller", default=(None, 1)
)

# UNECE Recommendation 20 common codes (OPC UA EUInformation.UnitId = the code's bytes)
_UNECE = {
    "m": ("MTR", "m", "metre"),
    "m/s": ("MTS", "m/s", "metre per second"),
    "m/s^2": ("MSK", "m/s²", "metre per second squared"),
    "rad": ("C81", "rad", "radian"),
    "rad/s": ("2A", "rad/s", "radian per second"),
    "rad/s^2": ("2B", "rad/s²", "radian per second squared"),
    "s": ("SEC", "s", "second"),
}
_UNECE_NS = "http://www.opcfoundation.org/UA/units/un/cefact"


class OpcUaStartError(RuntimeError):
    """The server did not start (the port is taken, a certificate cannot be read, ...)."""


def unit_id(code: str) -> int:
    """The OPC UA UnitId of a UNECE common code (its ASCII bytes, big-endian)."""
    v = 0
    for ch in code:
        v = (v << 8) | ord(ch)
    return v


def eu_information(unit: str) -> Any:
    """``ua.EUInformation`` of ``m``, ``m/s``, ``m/s^2``, ``rad``, ``rad/s``, ``rad/s^2``, ``s``."""
    from asyncua import ua

    code, sym, desc = _UNECE[unit]
    return ua.EUInformation(
        NamespaceUri=_UNECE_NS,
        UnitId=unit_id(code),
        DisplayName=ua.LocalizedText(sym),
        Description=ua.LocalizedText(desc),
    )


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nobody listens on now (for ``port: 0``)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


class OpcUaServer:
    """The OPC UA server of a machine whose :class:`OperatorDesk` is installed (``desk``: the
    desk itself, or the operator process' :class:`~motionplc.operator.server.RemoteDesk`).

    ``start()`` runs it in a thread of its own (its own asyncio loop) and returns once it
    listens (``endpoint``: ``opc.tcp://HOST:PORT/motionplc/``); ``stop()`` ends it.
    ``name``: the MotionDeviceSystem's browse name. ``switch_interval`` [s]: on the real-time
    clock the interpreter's thread switch interval is lowered to it while the server runs
    (``sys.setswitchinterval``; Python's default 5 ms is how long the cycle's thread may wait
    for the GIL the server's thread holds; None: left as it is).
    """

    def __init__(
        self,
        desk: OperatorDesk,
        settings: OpcUaSettings,
        name: str = "Machine",
        *,
        switch_interval: float | None = 0.0005,
    ) -> None:
        self.desk = desk
        self.switch_interval = switch_interval
        self._old_switch: float | None = None
        self.settings = settings
        self.name = name
        self.port = settings.port or free_port(settings.host)
        self.endpoint = f"opc.tcp://{settings.host}:{self.port}/motionplc/"
        self.certificate_path: Path | None = None
        self.updates = 0  # snapshots written into the address space
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._vars: list[tuple[Any, Callable[[Snapshot], Any], Any]] = []
        self._last: list[Any] = []
        self._login_ok: dict[tuple[str, bytes], bool] = {}
        self.layout = desk.layout
        self._units = {a.name: a.units for a in self.layout.axes}

    # -- life cycle --------------------------------------------------------------------------
    def start(self, timeout: float = 60.0) -> str:
        if self._thread is not None:
            return self.endpoint
        if self.switch_interval is not None and self.layout.realtime:
            self._old_switch = sys.getswitchinterval()
            sys.setswitchinterval(min(self._old_switch, self.switch_interval))
        self._thread = threading.Thread(target=self._main, name="motionplc-opcua", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise OpcUaStartError(f"the OPC UA server did not start within {timeout:g} s")
        if self._error is not None:
            raise OpcUaStartError(f"OPC UA server: {self._error}") from self._error
        return self.endpoint

    def stop(self, timeout: float = 10.0) -> None:
        loop, ev = self._loop, self._stop
        if loop is not None and ev is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(ev.set)
            except RuntimeError:  # the loop already ended
                pass
        if self._thread is not None:
            self._thread.join(timeout)
        if self._old_switch is not None:
            sys.setswitchinterval(self._old_switch)
            self._old_switch = None
        self.desk.close("the OPC UA server stopped")

    def __enter__(self) -> OpcUaServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _main(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._serve())
        except BaseException as exc:  # noqa: BLE001 - reported by start()
            self._error = exc
            LOG.debug("OPC UA server ended with an error", exc_info=True)
        finally:
            self._ready.set()
            loop.close()

    async def _serve(self) -> None:
        await self.serve(asyncio.Event(), self._ready.set)

    async def serve(self, stop: asyncio.Event, on_ready: Callable[[], None]) -> None:
        """Build the address space, listen, call ``on_ready`` and write the snapshots into
        the address space until ``stop`` is set (in the running event loop)."""
        from asyncua import Server

        self._stop = stop
        server = _make_server_class()(self)
        await server.init()
        await self._configure(server)
        await self._build(server)
        try:
            await server.start()
        except OSError as exc:
            raise OpcUaStartError(
                f"cannot listen on {self.settings.host}:{self.port} ({exc.strerror or exc})"
            ) from exc
        assert isinstance(server, Server)
        LOG.info("OPC UA server listening on %s", self.endpoint)
        on_ready()
        try:
            period = self.settings.publish_interval
            while not self._stop.is_set():
                await self._update(server)
                try:
                    await asyncio.wait_for(self._stop.wait(), period)
                except TimeoutError:
                    pass
        finally:
            await server.stop()

    # -- security ----------------------------------------------------------------------------
    async def _configure(self, server: Any) -> None:
        from asyncua import ua
        from asyncua.crypto.cert_gen import setup_self_signed_certificate
        from cryptography.x509.oid import ExtendedKeyUsageOID

        st = self.settings
        server.set_endpoint(self.endpoint)
        server.set_server_name(f"motionplc {self.name}")
        uri = f"urn:motionplc:{self.name}"
        await server.set_application_uri(uri)
        secure = [m for m in st.security if m != "None"]
        policies = []
        if "None" in st.security:
            policies.append(ua.SecurityPolicyType.NoSecurity)
        for m in secure:
            policies.append(getattr(ua.SecurityPolicyType, f"{st.policy}_{m}"))
        if secure:
            if st.certificate is not None:
                cert, key = Path(st.certificate), Path(st.private_key or "")
            else:
                d = Path(st.certificate_dir)
                d.mkdir(parents=True, exist_ok=True)
                cert, key = d / f"{self.name}_cert.der", d / f"{self.name}_key.pem"
                await setup_self_signed_certificate(
                    key,
                    cert,
                    uri,
                    socket.gethostname(),
                    [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
                    {
                        "countryName": "DE",
                        "organizationName": "motionplc",
                        "commonName": f"motionplc {self.name}",
                    },
                )
            await server.load_certificate(str(cert))
            await server.load_private_key(str(key))
            self.certificate_path = cert
        server.set_security_policy(policies)
        tokens: list[type] = []
        if st.anonymous:
            tokens.append(ua.AnonymousIdentityToken)
        if st.users:
            tokens.append(ua.UserNameIdentityToken)
        server.set_identity_tokens(tokens)

    def _get_user(self, username: str | None, password: str | None) -> Any:
        from asyncua.crypto.permission_rules import User, UserRole

        if username is None:
            return User(role=UserRole.Anonymous) if self.settings.anonymous else None
        stored = self.settings.user_hash(username)
        key = (username, hashlib.sha256((password or "").encode()).digest())
        ok = self._login_ok.get(key)
        if ok is None:
            ok = stored is not None and password is not None and check_password(password, stored)
            if len(self._login_ok) < 1000:
                self._login_ok[key] = ok
        if not ok:
            LOG.warning("OPC UA login refused for user %r", username)
            return None
        return User(role=UserRole.User, name=username)

    # -- the address space -------------------------------------------------------------------
    async def _build(self, server: Any) -> None:
        from asyncua import ua

        ns = await server.register_namespace(NAMESPACE)
        self.ns = ns
        desk = self.desk
        snap = desk.snapshot
        assert snap is not None, "install the desk first"
        lay = self.layout
        objects = server.nodes.objects
        device_set = await objects.add_folder(
            ua.NodeId("DeviceSet", ns), ua.QualifiedName("DeviceSet", ns)
        )
        system = await device_set.add_object(
            ua.NodeId(self.name, ns), ua.QualifiedName(self.name, ns)
        )
        await _prop(
            system, ns, f"{self.name}.ComponentName", "ComponentName", ua.LocalizedText(self.name)
        )
        devices = await system.add_folder(
            ua.NodeId(f"{self.name}.MotionDevices", ns), ua.QualifiedName("MotionDevices", ns)
        )
        controllers = await system.add_folder(
            ua.NodeId(f"{self.name}.Controllers", ns), ua.QualifiedName("Controllers", ns)
        )
        await system.add_folder(
            ua.NodeId(f"{self.name}.SafetyStates", ns), ua.QualifiedName("SafetyStates", ns)
        )
        in_group = {a: g.name for g in lay.groups for a in g.axes}
        ax_index = {a.name: i for i, a in enumerate(snap.axes)}
        g_index = {g.name: i for i, g in enumerate(snap.groups)}
        for g in lay.groups:
            dev = await self._device(devices, ns, g.name, "group")
            await self._group(dev, ns, g.name, g_index[g.name], g.axes)
            axes_folder = await dev.add_folder(
                ua.NodeId(f"{g.name}.Axes", ns), ua.QualifiedName("Axes", ns)
            )
            for a in g.axes:
                await self._axis(axes_folder, ns, a, ax_index[a])
        for spec in lay.axes:
            if spec.name in in_group:
                continue
            dev = await self._device(devices, ns, spec.name, "axis")
            axes_folder = await dev.add_folder(
                ua.NodeId(f"{spec.name}.Axes", ns), ua.QualifiedName("Axes", ns)
            )
            await self._axis(axes_folder, ns, spec.name, ax_index[spec.name], own_device=True)
        await self._controller(controllers, ns)
        self._last = [None] * len(self._vars)
        await self._update(server)

    async def _device(self, parent: Any, ns: int, name: str, kind: str) -> Any:
        from asyncua import ua

        dev = await parent.add_object(ua.NodeId(f"device.{name}", ns), ua.QualifiedName(name, ns))
        await _prop(
            dev, ns, f"device.{name}.Manufacturer", "Manufacturer", ua.LocalizedText("motionplc")
        )
        model = "axes group" if kind == "group" else "single axis"
        await _prop(dev, ns, f"device.{name}.Model", "Model", ua.LocalizedText(model))
        await _prop(dev, ns, f"device.{name}.ProductCode", "ProductCode", "motionplc")
        await _prop(dev, ns, f"device.{name}.SerialNumber", "SerialNumber", name)
        return dev

    def _var(self, node: Any, getter: Callable[[Snapshot], Any], vtype: Any) -> None:
        self._vars.append((node, getter, vtype))

    async def _axis(
        self, parent: Any, ns: int, name: str, i: int, own_device: bool = False
    ) -> None:
        from asyncua import ua

        vts = ua.VariantType
        spec = self.layout.axis(name)
        units = spec.units if spec.units in ("m", "rad") else "m"
        obj = await parent.add_object(ua.NodeId(f"axis.{name}", ns), ua.QualifiedName(name, ns))
        # OPC 40010-1 AxisMotionProfileEnumeration: ROTARY 1, ROTARY_ENDLESS 2, LINEAR 3,
        # LINEAR_ENDLESS 4
        profile = (2 if spec.modulo else 1) if units == "rad" else (4 if spec.modulo else 3)
        await _prop(obj, ns, f"axis.{name}.MotionProfile", "MotionProfile", profile, vts.Int32)
        ps = await obj.add_object(
            ua.NodeId(f"axis.{name}.ParameterSet", ns), ua.QualifiedName("ParameterSet", ns)
        )
        rng = {
            "": (spec.sw_limit_min, spec.sw_limit_max),
            "/s": (-abs(spec.v_min) if spec.v_min is not None else -spec.v_max, spec.v_max),
            "/s^2": (-abs(spec.a_min) if spec.a_min is not None else -spec.a_max, spec.a_max),
        }

        def analog(field: str, bname: str, suffix: str) -> Any:
            return self._analog(
                ps, ns, f"axis.{name}.{bname}", bname, i, field, units + suffix, rng[suffix]
            )

        await analog("actual_position", "ActualPosition", "")
        await analog("actual_velocity", "ActualSpeed", "/s")
        await analog("actual_acceleration", "ActualAcceleration", "/s^2")
        await analog("set_position", "SetPosition", "")
        await analog("set_velocity", "SetSpeed", "/s")
        await analog("set_acceleration", "SetAcceleration", "/s^2")
        await analog("following_error", "FollowingError", "")
        await self._plain(
            ps,
            ns,
            f"axis.{name}.PLCopenState",
            "PLCopenState",
            vts.String,
            lambda s: AxisState(s.axes[i].state).name,
        )
        await self._plain(
            ps,
            ns,
            f"axis.{name}.PLCopenStateValue",
            "PLCopenStateValue",
            vts.Int32,
            lambda s: s.axes[i].state,
        )
        await self._plain(
            ps, ns, f"axis.{name}.ErrorID", "ErrorID", vts.UInt32, lambda s: s.axes[i].error_id
        )
        await self._plain(
            ps,
            ns,
            f"axis.{name}.ErrorText",
            "ErrorText",
            vts.String,
            lambda s: _error_text(s.axes[i].error_id, s.axes[i].error_text),
        )
        await self._plain(
            ps, ns, f"axis.{name}.Powered", "Powered", vts.Boolean, lambda s: s.axes[i].powered
        )
        await self._plain(
            ps,
            ns,
            f"axis.{name}.SpeedOverride",
            "SpeedOverride",
            vts.Double,
            lambda s: 100.0 * s.axes[i].override,
        )
        if own_device:  # a one-axis motion device: its SpeedOverride is the axis'
            pass
        await self._methods(obj, ns, f"axis:{name}", f"axis.{name}", AXIS_METHODS)

    async def _group(self, dev: Any, ns: int, name: str, i: int, axes: tuple[str, ...]) -> None:
        from asyncua import ua

        vts = ua.VariantType
        ps = await dev.add_object(
            ua.NodeId(f"group.{name}.ParameterSet", ns), ua.QualifiedName("ParameterSet", ns)
        )
        units = {self._units.get(a, "m") for a in axes}
        u = units.pop() if len(units) == 1 else None
        if u in ("m", "rad"):
            await self._analog(
                ps,
                ns,
                f"group.{name}.PathVelocity",
                "PathVelocity",
                i,
                "path_velocity",
                u + "/s",
                (None, None),
                group=True,
            )
        else:
            await self._plain(
                ps,
                ns,
                f"group.{name}.PathVelocity",
                "PathVelocity",
                vts.Double,
                lambda s: s.groups[i].path_velocity,
            )
        await self._plain(
            ps,
            ns,
            f"group.{name}.Position",
            "Position",
            vts.Double,
            lambda s: list(s.groups[i].position),
        )
        await self._plain(
            ps,
            ns,
            f"group.{name}.PLCopenState",
            "PLCopenState",
            vts.String,
            lambda s: GroupState(s.groups[i].state).name,
        )
        await self._plain(
            ps,
            ns,
            f"group.{name}.PLCopenStateValue",
            "PLCopenStateValue",
            vts.Int32,
            lambda s: s.groups[i].state,
        )
        await self._plain(
            ps,
            ns,
            f"group.{name}.InControl",
            "InControl",
            vts.Boolean,
            lambda s: s.groups[i].state != int(GroupState.GROUP_DISABLED),
        )
        await self._plain(
            ps,
            ns,
            f"group.{name}.SpeedOverride",
            "SpeedOverride",
            vts.Double,
            lambda s: 100.0 * s.groups[i].override,
        )
        await self._plain(
            ps, ns, f"group.{name}.ErrorID", "ErrorID", vts.UInt32, lambda s: s.groups[i].error_id
        )
        await self._plain(
            ps,
            ns,
            f"group.{name}.ErrorText",
            "ErrorText",
            vts.String,
            lambda s: _error_text(s.groups[i].error_id, s.groups[i].error_text),
        )
        await self._methods(dev, ns, f"group:{name}", f"group.{name}", GROUP_METHODS)

    async def _controller(self, parent: Any, ns: int) -> None:
        from asyncua import ua

        vts = ua.VariantType
        lay = self.layout
        ctl = await parent.add_object(ua.NodeId("Runtime", ns), ua.QualifiedName("Runtime", ns))
        await _prop(ctl, ns, "Runtime.Manufacturer", "Manufacturer", ua.LocalizedText("motionplc"))
        await _prop(ctl, ns, "Runtime.Tick", "Tick", lay.tick, vts.Double)
        await _prop(ctl, ns, "Runtime.RealTime", "RealTime", lay.realtime, vts.Boolean)
        ps = await ctl.add_object(
            ua.NodeId("Runtime.ParameterSet", ns), ua.QualifiedName("ParameterSet", ns)
        )
        await self._plain(ps, ns, "Runtime.Cycle", "Cycle", vts.Int64, lambda s: s.cycle)
        await self._plain(ps, ns, "Runtime.Time", "Time", vts.Double, lambda s: s.t)
        await self._plain(ps, ns, "Runtime.SnapshotSeq", "SnapshotSeq", vts.Int64, lambda s: s.seq)
        tasks = await ctl.add_folder(ua.NodeId("Runtime.Tasks", ns), ua.QualifiedName("Tasks", ns))
        for j, t in enumerate(lay.tasks):
            tn = t.name
            to = await tasks.add_object(ua.NodeId(f"task.{tn}", ns), ua.QualifiedName(tn, ns))
            # OPC 30000 CtrlTaskType: Priority (UInt32), Interval (String)
            await _prop(
                to, ns, f"task.{tn}.Priority", "Priority", max(0, int(t.priority)), vts.UInt32
            )
            await _prop(
                to, ns, f"task.{tn}.Interval", "Interval", f"T#{t.period * 1e3:g}ms", vts.String
            )
            tps = await to.add_object(
                ua.NodeId(f"task.{tn}.ParameterSet", ns), ua.QualifiedName("ParameterSet", ns)
            )
            for field, bname, vt in (
                ("cycle_count", "CycleCount", vts.Int64),
                ("exec_last", "ExecLast", vts.Double),
                ("exec_max", "ExecMax", vts.Double),
                ("exec_mean", "ExecMean", vts.Double),
                ("lateness_max", "LatenessMax", vts.Double),
                ("overruns", "Overruns", vts.Int64),
            ):
                await self._plain(
                    tps,
                    ns,
                    f"task.{tn}.{bname}",
                    bname,
                    vt,
                    (lambda f, k: lambda s: getattr(s.tasks[k], f))(field, j),
                )
        prog = await ctl.add_object(ua.NodeId("Program", ns), ua.QualifiedName("Program", ns))
        for field, bname, vt in (
            ("kind", "Kind", vts.String),
            ("path", "Path", vts.String),
            ("state", "State", vts.String),
            ("line", "Line", vts.Int64),
            ("lines_run", "LinesRun", vts.Int64),
            ("lines_total", "LinesTotal", vts.Int64),
            ("progress", "Progress", vts.Double),
            ("message", "Message", vts.String),
        ):
            await self._plain(
                prog,
                ns,
                f"Program.{bname}",
                bname,
                vt,
                (lambda f: lambda s: getattr(s.program, f))(field),
            )
        await self._methods(prog, ns, "program", "Program", PROGRAM_METHODS)

    async def _plain(
        self, parent: Any, ns: int, nid: str, bname: str, vt: Any, getter: Callable[[Snapshot], Any]
    ) -> Any:
        from asyncua import ua

        snap = self.desk.snapshot
        assert snap is not None
        node = await parent.add_variable(
            ua.NodeId(nid, ns), ua.QualifiedName(bname, ns), ua.Variant(getter(snap), vt)
        )
        self._var(node, getter, vt)
        return node

    async def _analog(
        self,
        parent: Any,
        ns: int,
        nid: str,
        bname: str,
        i: int,
        field: str,
        unit: str,
        rng: tuple[float | None, float | None],
        group: bool = False,
    ) -> Any:
        from asyncua import ua

        if group:

            def getter(s: Snapshot) -> float:
                return float(getattr(s.groups[i], field))
        else:

            def getter(s: Snapshot) -> float:
                return float(getattr(s.axes[i], field))

        node = await self._plain(parent, ns, nid, bname, ua.VariantType.Double, getter)
        # OPC 10000-8 AnalogUnitType: EngineeringUnits (mandatory), EURange
        await node.delete_reference(
            ua.NodeId(ua.ObjectIds.BaseDataVariableType), ua.ObjectIds.HasTypeDefinition
        )
        await node.add_reference(
            ua.NodeId(ua.ObjectIds.AnalogUnitType),
            ua.ObjectIds.HasTypeDefinition,
            bidirectional=False,
        )
        eu = await node.add_property(
            ua.NodeId(f"{nid}.EngineeringUnits", ns),
            ua.QualifiedName("EngineeringUnits", 0),
            ua.Variant(eu_information(unit), ua.VariantType.ExtensionObject),
        )
        await eu.write_attribute(
            ua.AttributeIds.DataType,
            ua.DataValue(ua.Variant(ua.NodeId(ua.ObjectIds.EUInformation))),
        )
        lo, hi = rng
        if lo is not None and hi is not None:
            r = await node.add_property(
                ua.NodeId(f"{nid}.EURange", ns),
                ua.QualifiedName("EURange", 0),
                ua.Variant(ua.Range(Low=float(lo), High=float(hi)), ua.VariantType.ExtensionObject),
            )
            await r.write_attribute(
                ua.AttributeIds.DataType, ua.DataValue(ua.Variant(ua.NodeId(ua.ObjectIds.Range)))
            )
        return node

    async def _methods(
        self,
        obj: Any,
        ns: int,
        target: str,
        prefix: str,
        table: dict[str, tuple[tuple[str, str, str], ...]],
    ) -> None:
        from asyncua import ua

        kinds = {
            "bool": ua.ObjectIds.Boolean,
            "int": ua.ObjectIds.Int32,
            "float": ua.ObjectIds.Double,
            "str": ua.ObjectIds.String,
        }
        outs = []
        for n, t, d in (
            ("ErrorID", ua.ObjectIds.UInt32, "0: accepted, else the FB's ErrorID"),
            ("ErrorText", ua.ObjectIds.String, "why it was refused (empty: accepted)"),
            ("Cycle", ua.ObjectIds.Int64, "the cycle that acted on the call"),
        ):
            outs.append(_argument(n, t, d))
        for method, params in table.items():
            ins = [_argument(n, kinds[k], d) for n, k, d in params]
            await obj.add_method(
                ua.NodeId(f"{prefix}.{method}", ns),
                ua.QualifiedName(method, ns),
                self._handler(target, method, params),
                ins,
                outs,
            )

    def _handler(
        self, target: str, method: str, params: tuple[tuple[str, str, str], ...]
    ) -> Callable[..., Any]:
        from asyncua import ua

        async def call(parent: Any, *variants: Any) -> Any:
            user, mode = _CALLER.get()
            res = ua.CallMethodResult()
            res.InputArgumentResults = [ua.StatusCode() for _ in variants]
            if user is None or mode == int(ua.MessageSecurityMode.None_):
                # (the permission check refuses these before; a second line of defence)
                res.StatusCode = ua.StatusCode(ua.StatusCodes.BadUserAccessDenied)
                return res
            if len(variants) != len(params):
                res.StatusCode = ua.StatusCode(
                    ua.StatusCodes.BadArgumentsMissing
                    if len(variants) < len(params)
                    else ua.StatusCodes.BadTooManyArguments
                )
                return res
            args = []
            for k, ((pname, kind, _), v) in enumerate(zip(params, variants, strict=True)):
                x = v.Value if isinstance(v, ua.Variant) else v
                if not of_kind(kind, x):
                    res.InputArgumentResults[k] = ua.StatusCode(ua.StatusCodes.BadTypeMismatch)
                    res.StatusCode = ua.StatusCode(ua.StatusCodes.BadInvalidArgument)
                    text = f"{pname} must be {kind}, got {x!r}"
                    res.OutputArguments = _outs(int(ErrorID.INTERNAL_ERROR), text, -1)
                    LOG.info("operator %s: %s.%s refused: %s", user, target, method, text)
                    return res
                args.append(x)
            loop = asyncio.get_running_loop()
            fut: asyncio.Future[tuple[bool, int, str, int]] = loop.create_future()

            def reply(ok: bool, eid: int, text: str, cycle: int) -> None:
                loop.call_soon_threadsafe(_resolve, fut, (ok, eid, text, cycle))

            req = Request(target, method, tuple(args), user, reply)
            self.desk.submit(req)
            try:
                ok, eid, text, cycle = await asyncio.wait_for(fut, METHOD_TIMEOUT)
            except TimeoutError:
                res.StatusCode = ua.StatusCode(ua.StatusCodes.BadTimeout)
                res.OutputArguments = _outs(
                    int(ErrorID.INTERNAL_ERROR),
                    f"the cycle did not take the call within {METHOD_TIMEOUT:g} s",
                    -1,
                )
                return res
            if not ok:
                res.StatusCode = ua.StatusCode(_status_of(eid))
                for k, (pname, _, _) in enumerate(params):
                    if pname.lower() in text.lower():
                        res.InputArgumentResults[k] = ua.StatusCode(ua.StatusCodes.BadOutOfRange)
            res.OutputArguments = _outs(eid, text, cycle)
            return res

        return call

    # -- publishing --------------------------------------------------------------------------
    async def _update(self, server: Any) -> None:
        """Write the values of the last snapshot that changed (subscriptions see them)."""
        from asyncua import ua

        snap = self.desk.snapshot
        if snap is None or getattr(self, "_seq", None) == snap.seq:
            return
        self._seq = snap.seq
        last = self._last
        write = server.write_attribute_value
        for k, (node, getter, vt) in enumerate(self._vars):
            v = getter(snap)
            if v != last[k]:
                last[k] = v
                await write(node.nodeid, ua.DataValue(ua.Variant(v, vt)))
        self.updates += 1


def _make_server_class() -> Any:
    """asyncua's Server with the motionplc rights: a permission rule set per endpoint (it
    knows the channel's security mode) and the configured users."""
    from asyncua import Server, ua
    from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, UserRole

    call_types = {
        ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary),
        ua.NodeId(ua.ObjectIds.WriteRequest_Encoding_DefaultBinary),
        ua.NodeId(ua.ObjectIds.HistoryUpdateRequest_Encoding_DefaultBinary),
    }
    read_types = {ua.NodeId(t) for t in USER_TYPES} - call_types

    class Rules(PermissionRuleset):
        def __init__(self, mode: int) -> None:
            self.mode = int(mode)

        def check_validity(self, user: Any, action_type_id: Any, body: Any) -> bool:
            name = getattr(user, "name", None) if user is not None else None
            operator = (
                user is not None
                and user.role == UserRole.User
                and self.mode != int(ua.MessageSecurityMode.None_)
            )
            _CALLER.set((name if operator else None, self.mode))
            if action_type_id in read_types:
                return True
            if action_type_id in call_types:
                return operator
            return False

    class Users:
        def __init__(self, owner: OpcUaServer) -> None:
            self.owner = owner

        def get_user(
            self, iserver: Any, username: Any = None, password: Any = None, certificate: Any = None
        ) -> Any:
            return self.owner._get_user(username, password)

    class MachineServer(Server):
        def __init__(self, owner: OpcUaServer) -> None:
            super().__init__(user_manager=Users(owner))

        async def _setup_server_nodes(self) -> None:
            await super()._setup_server_nodes()
            for factory in self._policies:
                factory.permission_ruleset = Rules(factory.mode)

    return MachineServer


def _resolve(fut: asyncio.Future[Any], value: Any) -> None:
    if not fut.done():
        fut.set_result(value)


def _argument(name: str, type_id: int, description: str) -> Any:
    from asyncua import ua

    a = ua.Argument()
    a.Name = name
    a.DataType = ua.NodeId(type_id)
    a.ValueRank = -1
    a.ArrayDimensions = []
    a.Description = ua.LocalizedText(description)
    return a


def _outs(eid: int, text: str, cycle: int) -> list[Any]:
    from asyncua import ua

    return [
        ua.Variant(int(eid), ua.VariantType.UInt32),
        ua.Variant(text, ua.VariantType.String),
        ua.Variant(int(cycle), ua.VariantType.Int64),
    ]


def _status_of(eid: int) -> int:
    """The OPC UA status of a refused request: an input out of range is BadInvalidArgument,
    a state that does not allow it BadInvalidState, anything else BadRequestNotAllowed."""
    from asyncua import ua

    if 0x1000 <= eid < 0x2000:
        return ua.StatusCodes.BadInvalidArgument
    if 0x2000 <= eid < 0x4000:
        return ua.StatusCodes.BadInvalidState
    return ua.StatusCodes.BadRequestNotAllowed


def _error_text(eid: int, reason: str) -> str:
    if not eid:
        return ""
    try:
        name = ErrorID(eid).name
    except ValueError:
        name = str(eid)
    return f"{name} (0x{eid:04X})" + (f": {reason}" if reason else "")


async def _prop(obj: Any, ns: int, nid: str, bname: str, value: Any, vt: Any = None) -> Any:
    from asyncua import ua

    v = ua.Variant(value, vt) if vt is not None else ua.Variant(value)
    return await obj.add_property(ua.NodeId(nid, ns), ua.QualifiedName(bname, ns), v)
