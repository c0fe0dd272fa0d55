//! `robosim bridge` and `robosim sweep-host`: the clap arguments of robosim-bridge
//! (`robosim_bridge::run`, `robosim_bridge::sweep_link::host`), each converted to the library's plain argument type.

/// `robosim bridge` (exactly one of `--listen` and `--connect`).
#[derive(clap::Args, Debug, Clone)]
pub struct BridgeArgs {
    /// Serve this session's space on a Zenoh endpoint, e.g. tcp/0.0.0.0:7447 (the bridge
    /// listens there and nowhere else; no multicast scouting).
    #[arg(long, conflicts_with = "connect", required_unless_present = "connect")]
    pub listen: Option<String>,
    /// Keep this session a replica of the space served at a Zenoh endpoint, e.g.
    /// tcp/10.0.0.1:7447 (reconnects until stopped). The session must have no keeper: this
    /// bridge becomes its keeper, and the session's model is replaced by the primary's.
    #[arg(long)]
    pub connect: Option<String>,
    /// With --listen: refuse remote writers (replicas read; their transactions are refused
    /// with a clear error).
    #[arg(long, requires = "listen")]
    pub read_only: bool,
    /// Key prefix of this space on the Zenoh network (several spaces can share one network).
    #[arg(long, default_value = "robosim")]
    pub key: String,
    /// High-rate state services passed to the replica (`state/<name>`, the simulator's is
    /// `simulator`).
    #[arg(long = "state", default_value = "simulator")]
    pub states: Vec<String>,
    /// The most state records per second passed on per service (the newest is sent; the ones
    /// between are dropped). 0 passes none.
    #[arg(long, default_value_t = 30.0)]
    pub state_hz: f64,
    /// With --connect: how long a forwarded transaction waits for the primary's answer, ms.
    #[arg(long, default_value_t = 5000)]
    pub tx_timeout_ms: u64,
    /// Heartbeat period of the primary, ms (a replica that hears of a newer version catches up;
    /// how soon a restored link resynchronises when nothing is being written).
    #[arg(long, default_value_t = 200)]
    pub heartbeat_ms: u64,
}

impl From<BridgeArgs> for robosim_bridge::BridgeArgs {
    fn from(a: BridgeArgs) -> Self {
        robosim_bridge::BridgeArgs {
            listen: a.listen,
            connect: a.connect,
            read_only: a.read_only,
            key: a.key,
            states: a.states,
            state_hz: a.state_hz,
            tx_timeout_ms: a.tx_timeout_ms,
            heartbeat_ms: a.heartbeat_ms,
        }
    }
}
/// `robosim sweep-host`: runs sweep workers for coordinators on other machines.
#[derive(clap::Args, Debug, Clone)]
pub struct HostArgs {
    /// The Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7448 (only there; no multicast
    /// scouting, no gossip).
    #[arg(long)]
    pub listen: String,
    /// Worker processes run at most at once, for all coordinators together [default: one per
    /// core].
    #[arg(long)]
    pub workers: Option<usize>,
    /// Key prefix on the Zenoh network (the coordinator's `--remote-key` must match).
    #[arg(long, default_value = "robosim")]
    pub key: String,
}

impl From<HostArgs> for robosim_bridge::sweep_link::HostArgs {
    fn from(a: HostArgs) -> Self {
        robosim_bridge::sweep_link::HostArgs {
            listen: a.listen,
            workers: a.workers,
            key: a.key,
        }
    }
}
