//! `nomen explain`: why a track carries its identity at a time, from the decision traces of an
//! engine result.

use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::{
    CameraId, Candidate, DecisionRule, IdentifiedSkeleton, Identity, Message, SessionTime, TrackId,
};
use nomen_recording::RecordingReader;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

/// The most runs of one identity the timeline prints on each side of the asked time.
const TIMELINE_RUNS_EACH_SIDE: usize = 6;

/// Arguments of `nomen explain`.
#[derive(Debug, Args)]
pub struct ExplainArgs {
    /// An engine result (`nomen run --out`; `-` for stdin).
    pub result: PathBuf,
    /// The camera's track id.
    #[arg(long)]
    pub track: u64,
    /// Session time to explain, in seconds (`t` / 1e9); the track's message nearest to it is
    /// explained.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub at: f64,
    /// The camera, when several cameras have a track with this id (all of them otherwise).
    #[arg(long)]
    pub camera: Option<String>,
}

/// One run of a track's messages with the same identity and rule.
struct Run {
    identity: Identity,
    rule: Option<DecisionRule>,
    first: SessionTime,
    last: SessionTime,
    frames: usize,
}

/// What the result says about one camera's track: its timeline and the message nearest to the
/// asked time.
#[derive(Default)]
struct TrackStory {
    runs: Vec<Run>,
    nearest: Option<IdentifiedSkeleton>,
}

/// Runs `nomen explain`.
pub fn run(args: ExplainArgs) -> Result<()> {
    if !args.at.is_finite() || args.at.abs() > nomen_core::MAX_ABS_SESSION_TIME_S {
        bail!("--at {} is not a session time in seconds", args.at);
    }
    let at_ns = (args.at * 1e9).round() as i64;
    let track = TrackId(args.track);
    let camera = args.camera.as_deref().map(CameraId::new);
    let name = crate::io::source_name(&args.result);
    let reader = RecordingReader::open(&args.result)
        .with_context(|| format!("cannot read the result {name}"))?;
    let mut stories: BTreeMap<CameraId, TrackStory> = BTreeMap::new();
    let mut any_identified = false;
    for msg in reader {
        let Message::Identified(m) = msg? else {
            continue;
        };
        any_identified = true;
        if m.track != track || camera.as_ref().is_some_and(|c| *c != m.camera) {
            continue;
        }
        let story = stories.entry(m.camera.clone()).or_default();
        let rule = m.decision.as_ref().map(|d| d.rule);
        match story.runs.last_mut() {
            Some(run) if run.identity == m.identity && run.rule == rule => {
                run.last = m.t;
                run.frames += 1;
            }
            _ => story.runs.push(Run {
                identity: m.identity.clone(),
                rule,
                first: m.t,
                last: m.t,
                frames: 1,
            }),
        }
        let distance = |t: SessionTime| t.0.abs_diff(at_ns);
        if story
            .nearest
            .as_ref()
            .is_none_or(|n| distance(m.t) < distance(n.t))
        {
            story.nearest = Some(*m);
        }
    }
    if !any_identified {
        bail!("{name} holds no `identified` messages: is it an engine result (`nomen run --out`)?");
    }
    if stories.is_empty() {
        match &camera {
            Some(c) => bail!("{name} has no message of camera {c}'s track {}", args.track),
            None => bail!("{name} has no message of a track {}", args.track),
        }
    }
    let mut out = crate::io::stdout();
    for (camera, story) in &stories {
        let Some(m) = &story.nearest else {
            continue;
        };
        write_explanation(&mut out, camera, m, &story.runs)?;
    }
    Ok(())
}

fn write_explanation(
    out: &mut impl Write,
    camera: &CameraId,
    m: &IdentifiedSkeleton,
    runs: &[Run],
) -> Result<()> {
    writeln!(out, "{camera} track {} at {}", m.track.0, m.t)?;
    writeln!(
        out,
        "  identity    {} (confidence {:.3})",
        identity_name(&m.identity),
        m.confidence
    )?;
    match &m.decision {
        Some(d) => {
            writeln!(
                out,
                "  rule        {} — {}",
                d.rule.as_str(),
                rule_meaning(d.rule)
            )?;
            writeln!(out, "  decided at  {}", d.decided_at)?;
            if let Some(c) = &d.named {
                writeln!(out, "  named       {}", candidate(c))?;
            }
            if let Some(c) = &d.runner_up {
                let label = if d.named.is_some() {
                    "runner-up "
                } else {
                    "best      "
                };
                writeln!(out, "  {label}  {}", candidate(c))?;
            }
        }
        None => writeln!(out, "  rule        (the result carries no decision trace)")?,
    }
    for e in &m.evidence {
        writeln!(
            out,
            "  evidence    {} {}: {:.3}",
            e.modality, e.device, e.score
        )?;
    }
    // The track's identity over time, around the explained message.
    let here = runs
        .iter()
        .position(|r| r.first <= m.t && m.t <= r.last)
        .unwrap_or(0);
    let lo = here.saturating_sub(TIMELINE_RUNS_EACH_SIDE);
    let hi = (here + TIMELINE_RUNS_EACH_SIDE + 1).min(runs.len());
    writeln!(out, "  timeline ({} runs in all):", runs.len())?;
    if lo > 0 {
        writeln!(out, "    … {lo} earlier")?;
    }
    for (i, r) in runs.iter().enumerate().take(hi).skip(lo) {
        let mark = if i == here { ">" } else { " " };
        writeln!(
            out,
            "  {mark} {:>12.3} – {:>12.3} s  {:>5} frames  {:<12} {}",
            r.first.as_secs_f64(),
            r.last.as_secs_f64(),
            r.frames,
            identity_name(&r.identity),
            r.rule.map_or("-", DecisionRule::as_str)
        )?;
    }
    if hi < runs.len() {
        writeln!(out, "    … {} later", runs.len() - hi)?;
    }
    Ok(())
}

fn identity_name(identity: &Identity) -> String {
    match identity {
        Identity::Subject(s) => s.to_string(),
        Identity::Anonymous => "anonymous".to_owned(),
    }
}

fn candidate(c: &Candidate) -> String {
    format!("{} (score {:.3})", c.subject, c.score)
}

fn rule_meaning(rule: DecisionRule) -> &'static str {
    match rule {
        DecisionRule::Assigned => {
            "the camera's assignment gave the track this subject (score above the rejection threshold)"
        }
        DecisionRule::SuccessiveTrack => {
            "an earlier or later track of this camera that never coexisted with it holds the subject"
        }
        DecisionRule::EarlierDecision => "an earlier decision about this track named it",
        DecisionRule::ContinuedTrack => "the track that continues this one carries the name",
        DecisionRule::Stitched => {
            "the track continues an ended one and carries its name until its own first decision"
        }
        DecisionRule::OtherCameraView => "another camera's view of the person carries the name",
        DecisionRule::BelowThreshold => "no subject scores above the rejection threshold",
        DecisionRule::TakenByOtherTrack => "the best subject went to another track of the camera",
        DecisionRule::Excluded => {
            "the best subject is held by a coexisting track of the camera that scored better for it"
        }
        DecisionRule::HeldFarAway => {
            "the best subject is held by a better-scoring track of another camera, far from this one"
        }
        DecisionRule::HeldBack => {
            "the name is withheld: the subject's clocks are unknown and another track scores almost as well"
        }
        DecisionRule::NoEvidence => "no evidence about any subject yet",
        DecisionRule::Improbable => {
            "the name (shown as the runner-up) is less likely to be right than the run's minimum (min_name_probability; once more people were in view than subjects stream, open_set_min_name_probability, and a score of at least open_set_min_score)"
        }
    }
}
