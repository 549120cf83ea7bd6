//! `lander router`: a zenoh router for a coordinator and workers that
//! cannot reach each other directly. It is lander's own zenoh, so its
//! version always matches the sessions it relays between.

use anyhow::Context;
use clap::Args;
use lander_protocol::net::{self, listening, router_config, strangers_warning, NetOptions};
use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;
use std::path::PathBuf;
use zenoh::Wait;

#[derive(Args, Debug)]
pub struct RouterArgs {
    /// A zenoh JSON5 configuration, such as deploy/zenoh/router.json5;
    /// its mode must be "router" or left out.
    #[arg(long, short = 'c', value_name = "FILE")]
    config: Option<PathBuf>,
    /// Where to listen, such as tcp/0.0.0.0:7447, instead of the
    /// configuration's listen endpoints.
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// A file of `user:password` lines: only sessions presenting one of
    /// them may connect, the coordinator's included.
    #[arg(long, value_name = "FILE")]
    users: Option<PathBuf>,
}

/// Routes until SIGTERM or SIGINT, then closes the session and returns.
pub fn router(args: RouterArgs) -> anyhow::Result<()> {
    let options = NetOptions {
        listen: args.listen,
        config_file: args.config,
        users: args.users,
        ..NetOptions::default()
    };
    // zenoh's own default would be every interface; say where instead.
    anyhow::ensure!(
        !options.listen.is_empty() || options.config_file.is_some(),
        "lander router needs --listen ENDPOINT (such as tcp/0.0.0.0:7447) or a --config FILE"
    );
    let cfg = router_config(&options)?;
    let endpoints = listening(&cfg);
    // Registered before the session opens, so a signal during start-up
    // still stops the router cleanly.
    let mut signals = Signals::new([SIGTERM, SIGINT]).context("handling SIGTERM and SIGINT")?;
    let then_can = "join the runs it carries";
    if let Some(warning) = strangers_warning(&cfg, then_can, "pass --users or use mutual TLS") {
        tracing::warn!("{warning}");
    }
    if net::guard_tls(&cfg) {
        tracing::info!("{}", net::TLS_NOTE);
    }
    let session = zenoh::open(cfg)
        .wait()
        .map_err(net::fail("opening the router"))?;
    tracing::info!(
        "router {} listening on {}",
        session.zid(),
        endpoints.join(", ")
    );
    let signal = signals.forever().next();
    tracing::info!(
        "router stopped by signal {}; exiting",
        signal.map_or("?".into(), |s| s.to_string())
    );
    session
        .close()
        .wait()
        .map_err(net::fail("closing the router"))?;
    Ok(())
}
