//! `nomen serve`'s network loop: an MQTT client thread that decodes inputs into a bounded queue,
//! and the session loop that feeds the engine and publishes what it makes.

use crate::broker::BrokerAddr;
use crate::decode::{Input, decode_into};
use crate::health::{Health, HealthReport};
use crate::log::IdentityLog;
use crate::outbox::{ConnectionCounts, Outbox};
use crate::record::{RecordOptions, Recorder};
use crate::session::{IDLE_TICK, Output, Refusal, Session};
use crate::topics::{EVENT_TOPIC, HEALTH_TOPIC, INPUT_FILTER, input_source, output_topic};
use crate::{LiveError, Result};
use nomen_core::{Message, Registry, SkeletonObservation};
use rumqttc::{Client, Connection, Event, Outgoing, Packet, QoS};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{
    Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError, sync_channel,
};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// Where the decisions go besides MQTT (the CLI's `--out` file).
pub trait DecisionSink {
    /// A batch of decisions of the session whose registry is `registry`, in time order.
    fn write(&mut self, registry: &Registry, decisions: &[Message]) -> std::io::Result<()>;
    /// The service stops: flush.
    fn finish(&mut self) -> std::io::Result<()>;
}

/// What watches the service besides MQTT (the web viewer): it is handed the values the session
/// loop makes, as they are made, and must return at once (it runs on the session loop).
pub trait Observer {
    /// A session started with `registry` (also when the registry came with the command).
    fn registry(&mut self, registry: &Registry);
    /// The engine took this skeleton (its decision comes later, in [`Observer::outputs`], with
    /// the same camera, track and time; decisions carry no joints unless refined).
    fn skeleton(&mut self, skeleton: &SkeletonObservation);
    /// A batch of outputs (decisions in time order, then events), after they were logged.
    fn outputs(&mut self, outputs: &[Output]);
    /// A health report, as published.
    fn health(&mut self, report: &HealthReport);
}

/// How `serve` runs.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// The broker.
    pub broker: BrokerAddr,
    /// The MQTT client id.
    pub client_id: String,
    /// Capacity of the input queue (decoded messages).
    pub queue_capacity: usize,
    /// Capacity of the MQTT client's request queue.
    pub publish_capacity: usize,
    /// The most outputs kept until the broker acknowledges them ([`crate::outbox`]).
    pub outbox_capacity: usize,
    /// Period of the health reports.
    pub health_period: Duration,
    /// How long to wait for the first connection.
    pub connect_timeout: Duration,
    /// Record each session to MCAP files (`--record`); `None`: no recording.
    pub record: Option<RecordOptions>,
}

/// What a finished `serve` did.
#[derive(Debug, Clone, PartialEq)]
pub struct ServeSummary {
    /// The last health report (published at the end too).
    pub health: HealthReport,
    /// Decisions published.
    pub num_decisions: u64,
    /// Events published.
    pub num_events: u64,
    /// The MCAP files recorded, in order.
    pub recorded: Vec<std::path::PathBuf>,
}

/// How long a stopping service waits for the broker to acknowledge its last publishes.
const ACK_TIMEOUT: Duration = Duration::from_secs(10);

/// The state the client thread and the session loop share: the counts behind the health reports.
type SharedHealth = Arc<Mutex<Health>>;

/// What the client thread tells the session loop besides the queue.
#[derive(Default)]
struct Shared {
    /// Messages in the input queue (counted before they are queued, uncounted as the session
    /// loop takes them one by one).
    in_queue: AtomicUsize,
    /// The most messages the input queue holds.
    queue_capacity: usize,
    /// The connection, for the outbox.
    connection: ConnectionCounts,
    /// A registry that found the input queue full.
    pending_registry: Mutex<Option<Box<Registry>>>,
}

fn lock(health: &SharedHealth) -> std::sync::MutexGuard<'_, Health> {
    // The counts stay usable after a panic elsewhere.
    health.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Runs the live service until `stop` is set: connects to the broker, subscribes to the inputs,
/// runs `session` on them, publishes its outputs (QoS 1), a health report every period and,
/// at the end, the session's last decisions. `registry`, when given, starts the first session
/// before any registry message arrives. Every batch of outputs goes to `log` (committed) before
/// it is published, and to `sink` and `observer`.
pub fn serve(
    options: &ServeOptions,
    mut session: Session,
    registry: Option<Registry>,
    mut sink: Option<&mut dyn DecisionSink>,
    mut log: Option<IdentityLog>,
    mut observer: Option<&mut dyn Observer>,
    stop: &AtomicBool,
) -> Result<ServeSummary> {
    let started = Instant::now();
    let mqtt = options.broker.client_options(&options.client_id)?;
    let (client, connection) = Client::new(mqtt, options.publish_capacity);
    let health: SharedHealth = Arc::default();
    let (queue_in, queue) = sync_channel(options.queue_capacity);
    let (connected_tx, connected) = sync_channel(1);
    let shared = Arc::new(Shared {
        queue_capacity: options.queue_capacity,
        ..Shared::default()
    });
    // Dropped when the client thread ends.
    let (ended_tx, ended) = sync_channel::<()>(0);
    let network = {
        let shared = Arc::clone(&shared);
        let client = client.clone();
        let health = Arc::clone(&health);
        std::thread::Builder::new()
            .name("nomen-mqtt".to_owned())
            .spawn(move || {
                let _ended = ended_tx;
                run_client(
                    connection,
                    &client,
                    &health,
                    &queue_in,
                    &shared,
                    &connected_tx,
                )
            })
            .map_err(|e| LiveError::Io {
                what: "cannot start the mqtt thread".to_owned(),
                source: e,
            })?
    };
    match connected.recv_timeout(options.connect_timeout) {
        Ok(Ok(())) => {}
        Ok(Err(why)) => {
            return Err(LiveError::Mqtt {
                what: format!("connect to {}", options.broker),
                why: options.broker.connect_failure(&why),
            });
        }
        Err(_) => {
            return Err(LiveError::Mqtt {
                what: format!("connect to {}", options.broker),
                why: format!("no answer in {} s", options.connect_timeout.as_secs_f64()),
            });
        }
    }
    let mut out = Vec::new();
    let recorder = options.record.clone().map(Recorder::new).transpose()?;
    let mut publisher = Publisher {
        client: &client,
        shared: &shared,
        outbox: Outbox::new(options.outbox_capacity),
        num_reported_unpublished: 0,
        num_decisions: 0,
        num_events: 0,
        logged_session: 0,
        observed_session: 0,
        recorder,
        recorded_session: 0,
    };
    if let Some(registry) = registry {
        session.set_registry(registry, &mut out);
        publisher.publish(
            &mut out,
            &session,
            &mut sink,
            &mut log,
            &mut observer,
            &health,
        )?;
    }
    let mut last_message = Instant::now();
    let mut next_health = started + options.health_period;
    let mut result = Ok(());
    // The batch the client thread handed over last, taken one input a turn.
    let mut batch = Vec::new().into_iter();
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        let wait = next_health.saturating_duration_since(now).min(IDLE_TICK);
        let pending = shared
            .pending_registry
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        // A registry that waited in its own slot is this turn's input (its outputs are
        // published at the end of the turn, before the new session takes a message).
        let input = match pending {
            Some(registry) => Ok(Input::Registry(registry)),
            None => next_input(&mut batch, &queue, wait, &shared.in_queue),
        };
        match input {
            Ok(Input::Registry(registry)) => session.set_registry(*registry, &mut out),
            Ok(Input::Message(m)) => {
                last_message = Instant::now();
                match session.push(&m, last_message, &mut out) {
                    Ok(()) => {
                        if let Err(e) = publisher.record_input(&m, last_message) {
                            result = Err(e);
                            break;
                        }
                        if let Message::Skeleton(s) = &m {
                            if let Some(log) = log.as_mut() {
                                log.observe(s);
                            }
                            if let Some(observer) = observer.as_mut() {
                                observer.skeleton(s);
                            }
                        }
                    }
                    Err(refusal) => {
                        let mut h = lock(&health);
                        match (refusal, input_source(&m)) {
                            (Refusal::NoRegistry, _) => h.before_registry(),
                            (Refusal::Engine(why), Some((kind, source))) => {
                                h.rejected(kind, source, &why);
                            }
                            (Refusal::Engine(_), None) => {}
                        }
                    }
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                if last_message.elapsed() >= IDLE_TICK {
                    session.idle(Instant::now(), &mut out);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                result = Err(LiveError::Mqtt {
                    what: "client".to_owned(),
                    why: "the mqtt thread stopped".to_owned(),
                });
                break;
            }
        }
        let is_health_due = Instant::now() >= next_health;
        // Told once the broker is back (a warning made while it is away would find the outbox
        // full too, and be one more to tell).
        if is_health_due && shared.connection.is_connected() {
            publisher.warn_unpublished(&session, &mut out);
        }
        if let Err(e) = publisher.publish(
            &mut out,
            &session,
            &mut sink,
            &mut log,
            &mut observer,
            &health,
        ) {
            result = Err(e);
            break;
        }
        if is_health_due {
            next_health += options.health_period;
            let report = report(
                &health,
                started,
                &session,
                &shared.in_queue,
                options.queue_capacity,
                &publisher.outbox,
            );
            publisher.health(&report, &mut observer)?;
        }
    }
    // Stopped: take what is queued, then flush the engine (each turn's outputs published
    // before the next, so that a new registry's session starts after its predecessor's end).
    loop {
        let input = next_input(&mut batch, &queue, Duration::ZERO, &shared.in_queue).ok();
        let is_end = input.is_none();
        match input {
            Some(Input::Registry(registry)) => session.set_registry(*registry, &mut out),
            Some(Input::Message(m)) => {
                let now = Instant::now();
                if session.push(&m, now, &mut out).is_ok() {
                    publisher.record_input(&m, now)?;
                }
            }
            None => {
                session.finish(&mut out);
                publisher.warn_unpublished(&session, &mut out);
            }
        }
        publisher.publish(
            &mut out,
            &session,
            &mut sink,
            &mut log,
            &mut observer,
            &health,
        )?;
        if is_end {
            break;
        }
    }
    if let Some(sink) = sink {
        sink.finish().map_err(|e| LiveError::Io {
            what: "cannot write the decisions".to_owned(),
            source: e,
        })?;
    }
    let report = report(
        &health,
        started,
        &session,
        &shared.in_queue,
        options.queue_capacity,
        &publisher.outbox,
    );
    publisher.health(&report, &mut observer)?;
    let recorded = match publisher.recorder.take() {
        Some(recorder) => recorder.finish()?,
        None => Vec::new(),
    };
    let summary = ServeSummary {
        health: report,
        num_decisions: publisher.num_decisions,
        num_events: publisher.num_events,
        recorded,
    };
    // Wait for the broker's acknowledgements first: a socket closed with unread acks is reset,
    // and a broker may then drop the last publishes it had not read yet. Settled twice 20 ms
    // apart: a publish handed before a reconnection may still come after the counts matched.
    let waiting = Instant::now();
    let mut settled_since = None;
    while waiting.elapsed() < ACK_TIMEOUT {
        publisher.sync()?;
        if publisher.outbox.is_settled(&shared.connection.state()) {
            let since = *settled_since.get_or_insert_with(Instant::now);
            if since.elapsed() >= Duration::from_millis(20) {
                break;
            }
        } else {
            settled_since = None;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    // The disconnect goes after every publish queued before it; the client thread ends on it.
    // With the broker gone it may never be sent: the thread is then left behind, not waited for.
    let _ = client.try_disconnect();
    drop(queue);
    if ended.recv_timeout(Duration::from_secs(5)) == Err(RecvTimeoutError::Disconnected) {
        let _ = network.join();
    }
    result.map(|()| summary)
}

/// The next input: from `batch`, or else from the next batch of the queue (waiting at most
/// `wait`).
fn next_input(
    batch: &mut std::vec::IntoIter<Input>,
    queue: &Receiver<Vec<Input>>,
    wait: Duration,
    in_queue: &AtomicUsize,
) -> std::result::Result<Input, RecvTimeoutError> {
    loop {
        if let Some(input) = batch.next() {
            in_queue.fetch_sub(1, Ordering::Relaxed);
            return Ok(input);
        }
        let next = if wait.is_zero() {
            queue.try_recv().map_err(|e| match e {
                TryRecvError::Empty => RecvTimeoutError::Timeout,
                TryRecvError::Disconnected => RecvTimeoutError::Disconnected,
            })
        } else {
            queue.recv_timeout(wait)
        };
        *batch = next?.into_iter();
    }
}

fn report(
    health: &SharedHealth,
    started: Instant,
    session: &Session,
    in_queue: &AtomicUsize,
    capacity: usize,
    outbox: &Outbox,
) -> HealthReport {
    let mut report = lock(health).report(
        started.elapsed().as_secs_f64(),
        session.num_sessions(),
        (in_queue.load(Ordering::Relaxed).min(capacity), capacity),
    );
    report.num_unpublished = outbox.num_dropped();
    report.outbox_len = outbox.len();
    report.outbox_capacity = outbox.capacity();
    report
}

struct Publisher<'a> {
    client: &'a Client,
    shared: &'a Shared,
    /// What was published and not yet acknowledged.
    outbox: Outbox,
    /// The outbox's drops already told in a warning.
    num_reported_unpublished: u64,
    num_decisions: u64,
    num_events: u64,
    /// The session the log's rows go to (0: none yet).
    logged_session: u64,
    /// The session the observer was last told of (0: none yet).
    observed_session: u64,
    /// The MCAP recording (`--record`).
    recorder: Option<Recorder>,
    /// The session the recording's file is of (0: none yet).
    recorded_session: u64,
}

impl Publisher<'_> {
    fn publish(
        &mut self,
        out: &mut Vec<Output>,
        session: &Session,
        sink: &mut Option<&mut dyn DecisionSink>,
        log: &mut Option<IdentityLog>,
        observer: &mut Option<&mut dyn Observer>,
        health: &SharedHealth,
    ) -> Result<()> {
        self.sync()?;
        if !out.is_empty() {
            if let Some(log) = log.as_mut() {
                // Written and committed before anything is published.
                log.write(out)?;
            }
            if let Some(observer) = observer.as_mut() {
                observer.outputs(out);
            }
            if let Some(recorder) = self.recorder.as_mut() {
                recorder.outputs(out, Instant::now())?;
            }
            self.send_all(out, session, sink, health)?;
        }
        if let (Some(observer), Some(registry)) = (observer.as_mut(), session.registry())
            && session.num_sessions() != self.observed_session
        {
            observer.registry(registry);
            self.observed_session = session.num_sessions();
        }
        // A new session (after its predecessor's last outputs went to the old one).
        if let (Some(log), Some(registry)) = (log.as_mut(), session.registry())
            && session.num_sessions() != self.logged_session
        {
            let unix_ms = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| i64::try_from(d.as_millis()).unwrap_or(i64::MAX));
            log.begin_session(registry, unix_ms)?;
            self.logged_session = session.num_sessions();
        }
        if let (Some(recorder), Some(registry)) = (self.recorder.as_mut(), session.registry())
            && session.num_sessions() != self.recorded_session
        {
            recorder.begin_session(session.num_sessions(), registry, Instant::now())?;
            self.recorded_session = session.num_sessions();
        }
        Ok(())
    }

    /// An input the engine took, arrived at `at`, to the recording.
    fn record_input(&mut self, msg: &Message, at: Instant) -> Result<()> {
        match self.recorder.as_mut() {
            Some(recorder) => recorder.input(msg, at),
            None => Ok(()),
        }
    }

    fn send_all(
        &mut self,
        out: &mut Vec<Output>,
        session: &Session,
        sink: &mut Option<&mut dyn DecisionSink>,
        health: &SharedHealth,
    ) -> Result<()> {
        let mut num_decisions = 0;
        for o in out.iter() {
            match o {
                Output::Decision(m) => {
                    let Some(topic) = output_topic(m) else {
                        continue;
                    };
                    self.send(topic, to_json(m), true)?;
                    num_decisions += 1;
                }
                Output::Event(e) => {
                    self.send(EVENT_TOPIC.to_owned(), to_json(e), true)?;
                    self.num_events += 1;
                }
            }
        }
        self.num_decisions += num_decisions;
        lock(health).published(num_decisions);
        if let (Some(sink), Some(registry)) = (sink.as_mut(), session.registry()) {
            let decisions: Vec<Message> = out
                .iter()
                .filter_map(|o| match o {
                    Output::Decision(m) => Some(m.clone()),
                    Output::Event(_) => None,
                })
                .collect();
            sink.write(registry, &decisions)
                .map_err(|e| LiveError::Io {
                    what: "cannot write the decisions".to_owned(),
                    source: e,
                })?;
        }
        out.clear();
        Ok(())
    }

    fn health(
        &mut self,
        report: &HealthReport,
        observer: &mut Option<&mut dyn Observer>,
    ) -> Result<()> {
        if let Some(observer) = observer.as_mut() {
            observer.health(report);
        }
        if let Some(recorder) = self.recorder.as_mut() {
            recorder.health(report, Instant::now())?;
        }
        // A report made while the broker is away is stale before it could be sent.
        if !self.shared.connection.is_connected() {
            return Ok(());
        }
        self.send(HEALTH_TOPIC.to_owned(), to_json(report), false)
    }

    /// Publishes (QoS 1) through the outbox: `is_kept_on_loss`, published again after a
    /// reconnection unless the broker acknowledged it. A full outbox, the broker connected,
    /// waits for its acknowledgements (back-pressure); the broker away, it drops the publish
    /// (counted: the health reports and a warning say how many).
    fn send(&mut self, topic: String, payload: Vec<u8>, is_kept_on_loss: bool) -> Result<()> {
        while self.outbox.is_full() && self.shared.connection.is_connected() {
            self.sync()?;
            if self.outbox.is_full() {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        let _ = self.outbox.push(topic, payload, is_kept_on_loss);
        self.sync()
    }

    /// A warning event in `out` when the outbox dropped publishes since the last one: the
    /// identity log, written before anything is published, holds them.
    fn warn_unpublished(&mut self, session: &Session, out: &mut Vec<Output>) {
        let num_dropped = self.outbox.num_dropped();
        if num_dropped == self.num_reported_unpublished {
            return;
        }
        let num_new = num_dropped - self.num_reported_unpublished;
        self.num_reported_unpublished = num_dropped;
        out.push(Output::Event(crate::events::Event::warning(
            session.newest_ns(),
            format!(
                "{num_new} outputs not published ({num_dropped} in all): the outbox was full \
                 ({} kept until the broker acknowledges them) while the broker was away; the \
                 identity log holds them",
                self.outbox.capacity()
            ),
        )));
    }

    /// Forgets what the broker acknowledged, publishes again after a reconnection, hands what
    /// waits to the client.
    fn sync(&mut self) -> Result<()> {
        let client = self.client;
        self.outbox.sync(
            &self.shared.connection.state(),
            |topic: &str, payload: &[u8]| {
                client
                    .publish(topic, QoS::AtLeastOnce, false, payload.to_vec())
                    .map_err(|e| LiveError::Mqtt {
                        what: "publish".to_owned(),
                        why: e.to_string(),
                    })
            },
        )
    }
}

fn to_json<T: serde::Serialize>(value: &T) -> Vec<u8> {
    // Our own values always serialise (finite numbers, string keys).
    serde_json::to_vec(value).unwrap_or_default()
}

/// The most inputs the client thread hands to the session loop at once.
const MAX_BATCH: usize = 256;

/// What the client thread does after an event.
enum Flow {
    Go,
    /// The connection is over (a disconnect sent, the first connection failed, the session
    /// loop gone).
    End,
}

/// The client thread: keeps the connection (rumqttc reconnects), subscribes on every connection,
/// decodes what arrives into the bounded queue, and counts what it cannot use. The inputs of
/// the packets read together go to the queue together, as one batch: one hand-over (and at most
/// one wake-up of the session loop) for several messages, and no wait for more.
fn run_client(
    mut connection: Connection,
    client: &Client,
    health: &SharedHealth,
    queue: &SyncSender<Vec<Input>>,
    shared: &Shared,
    connected: &SyncSender<std::result::Result<(), String>>,
) {
    let mut client_state = ClientState {
        client,
        health,
        shared,
        connected,
        queue_capacity: shared.queue_capacity,
        is_first: true,
        decoded: Vec::new(),
        batch: Vec::new(),
    };
    loop {
        let Ok(event) = connection.recv() else {
            return;
        };
        let mut flow = client_state.handle(event);
        // The events rumqttc has already read (it reads up to 10 packets at a time) join the
        // batch: taken from its buffer, with no wait and no read of the socket.
        while matches!(flow, Flow::Go)
            && client_state.batch.len() < MAX_BATCH
            && !connection.eventloop.state.events.is_empty()
        {
            match connection.try_recv() {
                Ok(event) => flow = client_state.handle(event),
                Err(rumqttc::TryRecvError::Empty) => break,
                Err(rumqttc::TryRecvError::Disconnected) => flow = Flow::End,
            }
        }
        if let Flow::End = client_state.send_batch(queue) {
            return;
        }
        if let Flow::End = flow {
            return;
        }
    }
}

/// The client thread's state between events.
struct ClientState<'a> {
    client: &'a Client,
    health: &'a SharedHealth,
    shared: &'a Shared,
    connected: &'a SyncSender<std::result::Result<(), String>>,
    queue_capacity: usize,
    is_first: bool,
    /// The inputs of one payload (a vendor's holds several), reused.
    decoded: Vec<Input>,
    /// The inputs for the session loop, in arrival order.
    batch: Vec<Input>,
}

impl ClientState<'_> {
    fn handle(&mut self, event: std::result::Result<Event, rumqttc::ConnectionError>) -> Flow {
        match event {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                self.shared.connection.connected();
                // Never blocks: the request queue is drained by this very loop.
                let _ = self.client.try_subscribe(INPUT_FILTER, QoS::AtLeastOnce);
                if self.is_first {
                    self.is_first = false;
                    let _ = self.connected.try_send(Ok(()));
                }
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                if let Err(reason) = decode_into(&p.topic, &p.payload, &mut self.decoded) {
                    lock(self.health).malformed(&p.topic, &reason);
                    return Flow::Go;
                }
                let mut h = lock(self.health);
                let in_queue = self.shared.in_queue.load(Ordering::Relaxed);
                for input in self.decoded.drain(..) {
                    let Input::Message(m) = &input else {
                        // A registry is never dropped.
                        self.batch.push(input);
                        continue;
                    };
                    let Some((kind, source)) = input_source(m) else {
                        continue;
                    };
                    h.received(kind, source, m.t().as_ns());
                    // The queue's bound counts the messages sent and not yet taken, and those
                    // of this batch.
                    if in_queue + self.batch.len() >= self.queue_capacity {
                        h.dropped(kind, source);
                    } else {
                        self.batch.push(input);
                    }
                }
            }
            Ok(Event::Incoming(Packet::PubAck(_))) => {
                self.shared.connection.acked();
            }
            Ok(Event::Outgoing(Outgoing::Publish(_))) => {
                self.shared.connection.written();
            }
            Ok(Event::Outgoing(Outgoing::Disconnect)) => return Flow::End,
            Ok(_) => {}
            Err(e) => {
                if self.is_first {
                    let _ = self.connected.try_send(Err(e.to_string()));
                    return Flow::End;
                }
                self.shared.connection.disconnected();
                lock(self.health).connection_error(&e.to_string());
                // rumqttc reconnects on the next poll; do not spin while the broker is away.
                std::thread::sleep(Duration::from_millis(500));
            }
        }
        Flow::Go
    }

    /// Hands the batch to the session loop; `End` when it is gone.
    fn send_batch(&mut self, queue: &SyncSender<Vec<Input>>) -> Flow {
        if self.batch.is_empty() {
            return Flow::Go;
        }
        let batch = std::mem::take(&mut self.batch);
        // Counted before it is sent, so that the consumer's count never goes below zero.
        self.shared
            .in_queue
            .fetch_add(batch.len(), Ordering::Relaxed);
        match queue.try_send(batch) {
            Ok(()) => Flow::Go,
            // Not while the count bounds the messages (the channel holds as many batches as
            // the queue holds messages); if it were, the messages are dropped and counted and a
            // registry waits in a slot of its own, taken at the session loop's next turn
            // (waiting here could deadlock with a session loop waiting for this thread to send
            // its outputs).
            Err(TrySendError::Full(batch)) => {
                self.shared
                    .in_queue
                    .fetch_sub(batch.len(), Ordering::Relaxed);
                let mut h = lock(self.health);
                for input in batch {
                    match input {
                        Input::Registry(registry) => {
                            *self
                                .shared
                                .pending_registry
                                .lock()
                                .unwrap_or_else(PoisonError::into_inner) = Some(registry);
                        }
                        Input::Message(m) => {
                            if let Some((kind, source)) = input_source(&m) {
                                h.dropped(kind, source);
                            }
                        }
                    }
                }
                Flow::Go
            }
            Err(TrySendError::Disconnected(_)) => Flow::End,
        }
    }
}
