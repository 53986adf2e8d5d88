//! Signed V2V in a platoon's controller (`[security]`, docs/security.md): every vehicle signs
//! its broadcasts with a pseudonym of the run's simulated PKI (`platoon-security`), and every
//! receiver checks the seal before the packet checks may use the packet; a refusal drops the
//! packet and is counted by its reason ([`platoon_security::Refusal::name`]).
//!
//! Pure and seeded: the PKI and the pseudonyms come from a ChaCha20 stream seeded with
//! [`SecurityParams::seed`] (every platoon of a fleet draws the same root and authority, so
//! their vehicles trust each other), times are the run's (`k dt`, in ms), and signatures are
//! RFC 6979 deterministic: a signed run is the same bit for bit at the same seed.
//!
//! What a receiver refuses and when, by [`SecurityPolicy`]:
//! - `Every`: a delivery's seal is checked in full (certificate, validity, freshness and the
//!   ECDSA signature) before anything else looks at the packet.
//! - `OnDemand`: every check but the packet's signature first; the signature only for a packet
//!   the receiver acts on: a follower's packet that passed the packet checks (the law, the
//!   detectors or its maneuver machine read it), every packet the leader receives (its
//!   maneuver machine and its checks of maneuver messages read them).
//!
//! The receivers of one broadcast share its signature check ([`SignatureMemo`], cleared every
//! step): the same outcome, computed once per packet rather than once per receiver.

use crate::{Delivery, Packet};
use platoon_model::VehicleId;
use platoon_security::{
    AttachRule, Authority, Evidence, HashedId8, KeySlot, Keyring, Policy, RadarObservation,
    Refusal, Report, ReportOutcome, Revocation, SecurityHeader, SignatureMemo, Signer, Uplink,
    Verifier, VerifierConfig,
};
use platoon_v2v::Seal;
use std::collections::BTreeMap;

/// When a receiver verifies a packet's signature (`[security] policy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SecurityPolicy {
    /// Every packet received (`"every"`).
    Every,
    /// Only the packets a law or a maneuver acts on (`"on_demand"`, the US deployment
    /// studies' verify-on-demand); the other checks on every packet.
    OnDemand,
}

impl SecurityPolicy {
    /// Its name in config files and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Self::Every => "every",
            Self::OnDemand => "on_demand",
        }
    }
}

/// Signed V2V for one platoon's vehicles (`[security]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SecurityParams {
    /// Which packets have their signature verified.
    pub policy: SecurityPolicy,
    /// The longest time between two packets of a sender that carry its full certificate
    /// (ms): the standards' attach rule (1000).
    pub certificate_period_ms: u64,
    /// Every vehicle changes its pseudonym every this many ms of run time (0: never).
    pub pseudonym_change_ms: u64,
    /// The largest difference between a packet's generation time and the receiver's time it
    /// accepts (ms); further is refused as `stale`.
    pub freshness_ms: u64,
    /// The seed of the PKI's and the pseudonyms' keys.
    pub seed: u64,
    /// The platoon of a fleet these keys are for (`platoon_sim::Scenario::replica` sets it):
    /// every platoon draws the same PKI from `seed`, and its own pseudonyms (platoon 0 from
    /// the PKI's stream after it, platoon j from ChaCha20 stream j of the same seed), so no
    /// two vehicles of a fleet share a key.
    pub platoon: u16,
    /// Misbehaviour reports and revocation (`[security.reports]`); `None`: a detector's flag
    /// stays a flag.
    pub reports: Option<ReportParams>,
    /// A group key at join and a MAC under it (`[security.group]`); `None`: none.
    pub group: Option<crate::group_key::GroupParams>,
}

/// Misbehaviour reports and the authority that revokes on them (`[security.reports]`,
/// docs/security.md#misbehaviour-reports-and-revocation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReportParams {
    /// The uplink's latency from a reporter to the authority (ms).
    pub latency_ms: u64,
    /// The uplink's loss probability per report.
    pub loss: f64,
    /// The authority's rule: distinct reporting vehicles other than the accused...
    pub quorum: usize,
    /// ...whose counted reports arrived within this long of each other (ms).
    pub window_ms: u64,
    /// A reporter reports the same pseudonym at most this often (ms).
    pub every_ms: u64,
    /// A false report campaign (the catalogue's `false_reports`): an insider reporting an
    /// honest member.
    pub false_reports: Option<FalseReports>,
}

/// An insider's false report campaign: `reporter` reports `accused` whenever it receives a
/// packet of it (at most every `every_ms`) over `[start_ms, end_ms)`, the packet as evidence;
/// the authority cannot tell it from an honest report, so only its rule stands in the way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FalseReports {
    /// The insider who files them.
    pub reporter: VehicleId,
    /// The honest member it accuses.
    pub accused: VehicleId,
    /// From (ms).
    pub start_ms: u64,
    /// Until (ms, exclusive; `u64::MAX`: the end of the run).
    pub end_ms: u64,
}

impl Default for ReportParams {
    fn default() -> Self {
        let rule = platoon_security::AuthorityRule::default();
        Self {
            latency_ms: 100,
            loss: 0.0,
            quorum: rule.quorum,
            window_ms: rule.window_ms,
            every_ms: 1000,
            false_reports: None,
        }
    }
}

/// What the reports did so far: filed, lost on the uplink, and what the authority made of
/// those that arrived (by [`ReportOutcome::code`]). Which vehicles it revoked, and when, the
/// rows say ([`crate::FollowerStep::revoked`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReportCounts {
    /// Reports filed by the platoon's vehicles.
    pub filed: u64,
    /// Lost on the uplink.
    pub lost: u64,
    /// Arrived, by outcome (code - 1, [`ReportOutcome::NAMES`] order).
    pub outcomes: [u64; 9],
}

impl ReportCounts {
    /// `(name, count)` of every outcome, in order.
    pub fn by_outcome(&self) -> impl Iterator<Item = (&'static str, u64)> + '_ {
        ReportOutcome::NAMES.iter().copied().zip(self.outcomes)
    }

    /// As 11 numbers: filed, lost, then the outcomes (the wire's `ControlMsg::reports`).
    pub fn as_array(&self) -> [u64; 11] {
        let mut a = [0; 11];
        a[0] = self.filed;
        a[1] = self.lost;
        a[2..].copy_from_slice(&self.outcomes);
        a
    }

    /// [`ReportCounts::as_array`]'s inverse.
    pub fn from_array(a: [u64; 11]) -> Self {
        let mut outcomes = [0; 9];
        outcomes.copy_from_slice(&a[2..]);
        Self {
            filed: a[0],
            lost: a[1],
            outcomes,
        }
    }

    /// The sum of `self` and `other`.
    pub fn plus(&self, other: &ReportCounts) -> ReportCounts {
        let (a, b) = (self.as_array(), other.as_array());
        Self::from_array(std::array::from_fn(|i| a[i] + b[i]))
    }
}

/// A platoon's misbehaviour reporting: its uplink, the authority (every pseudonym of the
/// platoon enrolled), when each reporter last reported each pseudonym, and what happened.
#[derive(Debug, Clone)]
struct Reporting {
    params: ReportParams,
    uplink: Uplink,
    authority: Authority,
    last: BTreeMap<(usize, HashedId8), u64>,
    counts: ReportCounts,
    /// The authority's revocations, in order.
    revocations: Vec<Revocation>,
}

impl Reporting {
    fn new(params: ReportParams, security: &SecurityParams, keys: &Keyring) -> Self {
        let rule = platoon_security::AuthorityRule {
            quorum: params.quorum,
            window_ms: params.window_ms,
        };
        let authority = Authority::new(keys.pki().authority().certificate(), rule)
            .expect("the PKI's authority is an authority");
        // Its own stream of the seed: its losses never shift the keys'.
        let seed = security.seed ^ 0x7265_706f_7274_7300 ^ u64::from(security.platoon);
        let mut reporting = Self {
            params,
            uplink: Uplink::new(params.latency_ms, params.loss, seed),
            authority,
            last: BTreeMap::new(),
            counts: ReportCounts::default(),
            revocations: Vec::new(),
        };
        reporting.enrol(keys, 0);
        reporting
    }

    /// Enrols epoch `epoch` of `keys`: the PKI's enrolment links each pseudonym to its vehicle.
    fn enrol(&mut self, keys: &Keyring, epoch: usize) {
        for vehicle in 0..keys.vehicles() {
            if let Some(p) = keys.pseudonym(KeySlot { epoch, vehicle }) {
                self.authority
                    .enrol(vehicle as u32, p.certificate())
                    .expect("the PKI's pseudonyms enrol");
            }
        }
    }
}

impl SecurityParams {
    /// What signing adds to a packet on the air, on average (bytes, rounded up), for a radio
    /// model that takes one packet size: the standards' overhead (IEEE 1609.2 / ETSI TS 103
    /// 097, [`platoon_security::STANDARD_DIGEST_OVERHEAD`] with the signer's digest,
    /// [`platoon_security::STANDARD_CERTIFICATE_OVERHEAD`] with its certificate), the
    /// certificate on one packet in `beacon_hz` x the certificate period (every packet when
    /// that is under one); with a group key tagging every beacon (`[security.group] mac =
    /// "all"`), its tag on each ([`crate::group_key::TAG_BYTES`]; the rarer maneuver
    /// messages' tags and keys are not counted).
    pub fn mean_overhead_bytes(&self, beacon_hz: f64) -> u32 {
        let per_period = beacon_hz * self.certificate_period_ms as f64 / 1e3;
        let share = if per_period > 1.0 {
            1.0 / per_period
        } else {
            1.0
        };
        let (digest, cert) = (
            platoon_security::STANDARD_DIGEST_OVERHEAD as f64,
            platoon_security::STANDARD_CERTIFICATE_OVERHEAD as f64,
        );
        let tag = match self.group {
            Some(g) if g.mac == crate::group_key::GroupMac::All => crate::group_key::TAG_BYTES,
            _ => 0,
        };
        (digest + (cert - digest) * share).ceil() as u32 + tag
    }
}

impl SecurityParams {
    /// The platoon's keys at this seed ([`Keyring`]), for `vehicles` vehicles: the ones its
    /// vehicles sign with, and the ones an insider, a thief, the authority and the ground
    /// truth derive.
    pub fn keyring(&self, vehicles: usize) -> Keyring {
        Keyring::new(self.seed, self.platoon, vehicles)
    }

    /// The run's time at step `k` of `dt` seconds (ms): the time signatures carry.
    pub fn now_ms(k: u64, dt: f64) -> u64 {
        (k as f64 * dt * 1e3).round() as u64
    }

    /// Whether every vehicle takes its next pseudonym at step `k` (a step whose time crosses
    /// a multiple of `pseudonym_change_ms`; never with 0).
    pub fn changes_pseudonyms_at(&self, k: u64, dt: f64) -> bool {
        let change = self.pseudonym_change_ms;
        change > 0 && k > 0 && Self::now_ms(k, dt) / change > Self::now_ms(k - 1, dt) / change
    }
}

impl Default for SecurityParams {
    fn default() -> Self {
        Self {
            policy: SecurityPolicy::Every,
            certificate_period_ms: AttachRule::STANDARD.period_ms,
            pseudonym_change_ms: 0,
            freshness_ms: VerifierConfig::default().freshness_ms,
            seed: 0,
            platoon: 0,
            reports: None,
            group: None,
        }
    }
}

/// What a platoon's seals did so far: packets signed, deliveries whose signature was verified
/// (computed, or shared from the step's memo), refusals by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SealCounts {
    /// Packets signed.
    pub signed: u64,
    /// Signatures of packets checked (each delivery whose signature was verified, by a
    /// computation or from the step's memo).
    pub verified: u64,
    /// Refused deliveries by [`Refusal::code`] - 1.
    pub refused: [u64; 14],
    /// Packets tagged with the platoon's group key (`[security.group]`; 0 without).
    pub tagged: u64,
    /// The leader's renewals of the group key (one per member that left while holding it).
    pub renewals: u64,
    /// The misbehaviour reports (`[security.reports]`; zeros without).
    pub reports: ReportCounts,
}

impl SealCounts {
    /// All but the reports as 18 numbers: signed, verified, refused by code, tagged,
    /// renewals (the wire's `ControlMsg::seals`).
    pub fn as_array(&self) -> [u64; 18] {
        let mut a = [0; 18];
        a[0] = self.signed;
        a[1] = self.verified;
        a[2..16].copy_from_slice(&self.refused);
        a[16] = self.tagged;
        a[17] = self.renewals;
        a
    }

    /// [`SealCounts::as_array`]'s inverse, with `reports`.
    pub fn from_array(a: [u64; 18], reports: ReportCounts) -> Self {
        let mut refused = [0; 14];
        refused.copy_from_slice(&a[2..16]);
        Self {
            signed: a[0],
            verified: a[1],
            refused,
            tagged: a[16],
            renewals: a[17],
            reports,
        }
    }

    /// Refused deliveries in all.
    pub fn refused_total(&self) -> u64 {
        self.refused.iter().sum()
    }

    /// `(name, count)` of every reason, in code order.
    pub fn by_reason(&self) -> impl Iterator<Item = (&'static str, u64)> + '_ {
        Refusal::ALL
            .iter()
            .zip(self.refused)
            .map(|(r, n)| (r.name(), n))
    }

    /// The sum of `self` and `other`.
    pub fn plus(mut self, other: &SealCounts) -> SealCounts {
        self.signed += other.signed;
        self.verified += other.verified;
        self.tagged += other.tagged;
        self.renewals += other.renewals;
        for (a, b) in self.refused.iter_mut().zip(other.refused) {
            *a += b;
        }
        self.reports = self.reports.plus(&other.reports);
        self
    }
}

/// A monotonic clock (ns) the runtime lends the seals to time their cryptography with
/// (`timing.json`'s `sign` and `verify`, docs/security.md). The pure core never reads a clock of
/// its own: without one (the default) nothing is timed, and what a run computes never depends
/// on it.
pub type CryptoClock = fn() -> u64;

/// The time the seals spent so far by their [`CryptoClock`] (ns): signing (every packet of a
/// step, [`Sealing::seal`]) and checking deliveries' seals (decoding, certificate, signature
/// or the step's memo of it).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CryptoTime {
    /// Signing.
    pub sign_ns: u64,
    /// Verifying.
    pub verify_ns: u64,
}

impl CryptoTime {
    /// The sum of `self` and `other`.
    pub fn plus(self, other: &CryptoTime) -> CryptoTime {
        CryptoTime {
            sign_ns: self.sign_ns + other.sign_ns,
            verify_ns: self.verify_ns + other.verify_ns,
        }
    }
}

/// One platoon's signers (the leader's first) and receivers' verifiers (the leader's first).
#[derive(Debug, Clone)]
pub struct Sealing {
    params: SecurityParams,
    dt: f64,
    keys: Keyring,
    signers: Vec<Signer>,
    verifiers: Vec<Verifier>,
    memo: SignatureMemo,
    counts: SealCounts,
    reporting: Option<Box<Reporting>>,
    /// The platoon's group key (`[security.group]`).
    group: Option<Box<crate::group_key::Grouping>>,
    /// The runtime's clock, if it times the crypto, and what it measured.
    clock: Option<CryptoClock>,
    spent: CryptoTime,
}

impl Sealing {
    /// Signers and verifiers for `vehicles` vehicles (the leader included) stepped every `dt`
    /// seconds.
    pub fn new(params: SecurityParams, vehicles: usize, dt: f64) -> Self {
        Self::with_outside(params, vehicles, dt, &[])
    }

    /// [`Sealing::new`] for a platoon whose followers in `outside` are not members when the
    /// run starts (joiners): they hold no group key until a join gives them one
    /// (`[security.group]`).
    pub fn with_outside(
        params: SecurityParams,
        vehicles: usize,
        dt: f64,
        outside: &[VehicleId],
    ) -> Self {
        // The PKI and the pseudonyms, and those of later changes (platoon j > 0 of a fleet on
        // stream j), valid for the whole run, whatever its length.
        let keys = params.keyring(vehicles);
        let rule = AttachRule {
            period_ms: params.certificate_period_ms,
        };
        let signers = (0..vehicles)
            .map(|v| {
                let first = keys.pseudonym(KeySlot {
                    epoch: 0,
                    vehicle: v,
                });
                Signer::new(first.expect("epoch 0 is drawn").clone(), rule)
            })
            .collect();
        let config = VerifierConfig {
            freshness_ms: params.freshness_ms,
        };
        let verifiers = vec![keys.pki().verifier(config); vehicles];
        Self {
            params,
            dt,
            signers,
            verifiers,
            memo: SignatureMemo::new(),
            counts: SealCounts::default(),
            reporting: params
                .reports
                .map(|r| Box::new(Reporting::new(r, &params, &keys))),
            group: params
                .group
                .map(|g| Box::new(crate::group_key::Grouping::new(g, &keys, vehicles, outside))),
            keys,
            clock: None,
            spent: CryptoTime::default(),
        }
    }

    /// The run's time at step `k` (ms).
    pub fn now_ms(&self, k: u64) -> u64 {
        SecurityParams::now_ms(k, self.dt)
    }

    /// Its settings.
    pub fn params(&self) -> &SecurityParams {
        &self.params
    }

    /// What its seals (and its reports) did so far.
    pub fn counts(&self) -> SealCounts {
        SealCounts {
            reports: self.reports().copied().unwrap_or_default(),
            tagged: self.group.as_ref().map_or(0, |g| g.tagged),
            renewals: self.group.as_ref().map_or(0, |g| g.renewals),
            ..self.counts
        }
    }

    /// Times its signing and verifying with `clock` from now on ([`Sealing::crypto_time`]).
    pub fn time_with(&mut self, clock: CryptoClock) {
        self.clock = Some(clock);
    }

    /// The time its cryptography took so far (0 without a clock).
    pub fn crypto_time(&self) -> CryptoTime {
        self.spent
    }

    /// Signs `packets`, sent at step `k`, each with its sender's pseudonym (a sender it has no
    /// signer for sends unsealed: its packets are refused). At the steps of a pseudonym
    /// change, every vehicle first takes a new pseudonym (in vehicle order, from the seeded
    /// stream).
    pub fn seal(&mut self, k: u64, packets: &mut [Packet]) {
        let now = self.now_ms(k);
        if self.params.changes_pseudonyms_at(k, self.dt) {
            let next = self.keys.draw_epoch();
            for (s, p) in self.signers.iter_mut().zip(next) {
                s.change_pseudonym(p.clone());
            }
            if let Some(r) = &mut self.reporting {
                let epoch = self.keys.epochs() - 1;
                r.enrol(&self.keys, epoch);
                // The PKI issues a revoked vehicle nothing it would trust: its new pseudonym
                // is as revoked as its old ones.
                for rev in &r.revocations {
                    let slot = KeySlot {
                        epoch,
                        vehicle: rev.vehicle as usize,
                    };
                    if let Some(p) = self.keys.pseudonym(slot) {
                        for v in &mut self.verifiers {
                            v.revoke(p.digest());
                        }
                    }
                }
            }
        }
        let started = self.clock.map(|c| c());
        for p in packets {
            let Some(signer) = self.signers.get_mut(p.sender.index()) else {
                continue;
            };
            if let Some(g) = &mut self.group {
                g.fields(p, &self.keys);
            }
            let header = signer.sign(&p.signed_bytes(), now);
            p.seal = Seal::new(&header.to_bytes());
            self.counts.signed += 1;
        }
        if let (Some(clock), Some(t0)) = (self.clock, started) {
            self.spent.sign_ns += clock().saturating_sub(t0);
        }
    }

    /// What the reports did so far (`[security.reports]` only).
    pub fn reports(&self) -> Option<&ReportCounts> {
        self.reporting.as_ref().map(|r| &r.counts)
    }

    /// The authority's revocations so far, in order (`[security.reports]` only): whom, every
    /// pseudonym it held, when, and whose reports made the quorum.
    pub fn revocations(&self) -> &[Revocation] {
        self.reporting.as_ref().map_or(&[], |r| &r.revocations)
    }

    /// Vehicle `reporter`'s detector `detector` flagged `packet` at step `k`, its radar seeing
    /// `observed`: a report of the packet's signer to the authority, with the packet as
    /// evidence, signed by the reporter, unless it reported that pseudonym within
    /// `every_ms` (or the run has no reports, or the packet no seal).
    pub fn report(
        &mut self,
        k: u64,
        reporter: VehicleId,
        packet: &Packet,
        detector: u8,
        observed: Option<RadarObservation>,
    ) {
        let now = self.now_ms(k);
        let (Some(r), Some(seal)) = (self.reporting.as_mut(), packet.seal) else {
            return;
        };
        let Ok(header) = SecurityHeader::decode(seal.as_bytes()) else {
            return;
        };
        let Some(signer) = self.signers.get(reporter.index()) else {
            return;
        };
        let accused = header.signer.digest();
        let key = (reporter.index(), accused);
        if (r.last.get(&key)).is_some_and(|&t| now.saturating_sub(t) < r.params.every_ms) {
            return;
        }
        r.last.insert(key, now);
        let report = Report {
            accused,
            detector,
            filed_ms: now,
            evidence: vec![Evidence {
                payload: packet.signed_bytes().to_vec(),
                header,
            }],
            observed,
        };
        r.counts.filed += 1;
        if !r.uplink.send(report.sign(signer, now), now) {
            r.counts.lost += 1;
        }
    }

    /// The end of step `k`'s reporting: the reports that reach the authority by now are
    /// decided on, and every receiver puts the pseudonyms of a vehicle it revokes on its
    /// revocation list (its packets are refused as `revoked` from the next delivery on).
    /// The vehicles revoked at this step.
    pub fn decide(&mut self, k: u64) -> Vec<VehicleId> {
        let now = self.now_ms(k);
        let Some(r) = self.reporting.as_mut() else {
            return Vec::new();
        };
        let mut revoked = Vec::new();
        for (at, report) in r.uplink.arrivals(now) {
            let (outcome, revocation) = r.authority.receive(&report, at);
            r.counts.outcomes[usize::from(outcome.code()) - 1] += 1;
            if let Some(rev) = revocation {
                for v in &mut self.verifiers {
                    for &d in &rev.pseudonyms {
                        v.revoke(d);
                    }
                }
                revoked.push(VehicleId(rev.vehicle as u16));
                r.revocations.push(rev);
            }
        }
        revoked
    }

    /// Whether the leader has a renewed group key left to send (`[security.group]`): it then
    /// broadcasts at this step.
    pub fn leader_has_keys_to_send(&self) -> bool {
        self.group
            .as_ref()
            .is_some_and(|g| g.leader_has_keys_to_send())
    }

    /// The group key's check of delivery `d` at step `k`, after its seal's
    /// (`[security.group]`; nothing without): the receiver takes the keys the packet carries
    /// for it (their signature checked first under `OnDemand`), then a protected message needs
    /// a valid tag under its key. `membership`: the receiver is a member of its platoon (it
    /// has not left), and it counts the sender as one. Refused: counted, and the reason.
    pub fn check_group(
        &mut self,
        k: u64,
        d: &Delivery,
        membership: (bool, bool),
    ) -> Result<(), Refusal> {
        let Some(g) = &self.group else {
            return Ok(());
        };
        if self.params.policy == SecurityPolicy::OnDemand
            && g.carries_keys_for(d.receiver, &d.packet)
        {
            self.check(k, d, Policy::Every)?;
        }
        let Some(g) = &mut self.group else {
            return Ok(());
        };
        let started = self.clock.map(|c| c());
        let outcome = g.receive(d.receiver, &d.packet, membership);
        if let (Some(clock), Some(t0)) = (self.clock, started) {
            self.spent.verify_ns += clock().saturating_sub(t0);
        }
        if let Err(why) = outcome {
            self.counts.refused[usize::from(why.code()) - 1] += 1;
        }
        outcome
    }

    /// Starts step `k`'s deliveries: the memo of the last step's signatures goes.
    pub fn begin_step(&mut self) {
        self.memo.clear();
    }

    /// The first check of a delivery at step `k`, by the policy (`Every`: in full;
    /// `OnDemand`: all but the signature). Refused: counted, and the reason.
    pub fn screen(&mut self, k: u64, d: &Delivery) -> Result<(), Refusal> {
        let policy = match self.params.policy {
            SecurityPolicy::Every => Policy::Every,
            SecurityPolicy::OnDemand => Policy::OnDemand,
        };
        self.check(k, d, policy)
    }

    /// The signature check of a delivery the receiver acts on, under `OnDemand` (under
    /// `Every`, [`Sealing::screen`] made it already: nothing to do).
    pub fn confirm(&mut self, k: u64, d: &Delivery) -> Result<(), Refusal> {
        match self.params.policy {
            SecurityPolicy::Every => Ok(()),
            SecurityPolicy::OnDemand => self.check(k, d, Policy::Every),
        }
    }

    fn check(&mut self, k: u64, d: &Delivery, policy: Policy) -> Result<(), Refusal> {
        let now = self.now_ms(k);
        let started = self.clock.map(|c| c());
        let outcome = match (&d.packet.seal, self.verifiers.get_mut(d.receiver.index())) {
            // A receiver outside the platoon's vehicles takes nothing.
            (_, None) => Err(Refusal::UnknownCertificate),
            // A packet forged from nothing (or stripped of its seal).
            (None, _) => Err(Refusal::Truncated),
            (Some(seal), Some(v)) => SecurityHeader::decode(seal.as_bytes()).and_then(|h| {
                v.check_shared(&mut self.memo, &d.packet.signed_bytes(), &h, now, policy)
            }),
        };
        if let (Some(clock), Some(t0)) = (self.clock, started) {
            self.spent.verify_ns += clock().saturating_sub(t0);
        }
        match outcome {
            Ok(a) => {
                if a.signature == platoon_security::SignatureCheck::Verified {
                    self.counts.verified += 1;
                }
                Ok(())
            }
            Err(why) => {
                self.counts.refused[usize::from(why.code()) - 1] += 1;
                // The standards' answer to an unknown digest: the sender attaches its
                // certificate to its next packet (here at once; the request rides on the
                // receiver's next broadcast in the field).
                if why == Refusal::UnknownCertificate {
                    if let Some(s) = self.signers.get_mut(d.packet.sender.index()) {
                        s.request_certificate();
                    }
                }
                Err(why)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_model::{State, VehicleId};

    #[test]
    fn the_mean_overhead_weighs_the_certificate_by_its_share() {
        let p = SecurityParams::default();
        // 10 Hz, a certificate a second: one packet in ten carries it.
        assert_eq!(
            p.mean_overhead_bytes(10.0),
            (94.0f64 + 125.0 / 10.0).ceil() as u32
        );
        // Slower than the certificate period: every packet carries it.
        assert_eq!(p.mean_overhead_bytes(0.5), 219);
        assert_eq!(p.mean_overhead_bytes(1.0), 219);
        // A group key on every beacon adds its tag; on maneuver messages alone, nothing.
        let tagged = |mac| SecurityParams {
            group: Some(crate::group_key::GroupParams { mac }),
            ..p
        };
        use crate::group_key::GroupMac;
        assert_eq!(tagged(GroupMac::All).mean_overhead_bytes(1.0), 219 + 21);
        assert_eq!(tagged(GroupMac::Maneuvers).mean_overhead_bytes(1.0), 219);
    }

    #[test]
    fn a_seals_refusal_has_its_reasons_name_and_a_wire_code_of_its_own() {
        use crate::RefusedBy;
        for r in Refusal::ALL {
            let by = RefusedBy::Seal(r.code());
            assert_eq!(by.name(), r.name());
            assert_eq!(by.code(), 9 + r.code());
            assert_eq!(RefusedBy::from_code(by.code()), Some(by));
            assert!(by.by_checks() && by.refuses_packet());
            assert!(RefusedBy::ALL.iter().all(|o| o.code() != by.code()));
        }
        assert_eq!(RefusedBy::from_code(24), None);
        // Codes fit the wire's field (bits 2-7 of Inspection::flags).
        assert!(RefusedBy::Seal(14).code() < 64);
    }

    #[test]
    fn the_seal_holds_the_longest_header() {
        assert_eq!(Seal::CAPACITY, platoon_security::CERTIFICATE_HEADER_LEN);
    }

    fn delivery(to: u16, packet: Packet) -> Delivery {
        Delivery {
            receiver: VehicleId(to),
            packet,
        }
    }

    #[test]
    fn genuine_packets_pass_and_altered_or_forged_ones_are_refused_by_reason() {
        let mut s = Sealing::new(SecurityParams::default(), 3, 0.01);
        let mut out = [Packet::beacon(
            VehicleId(1),
            1,
            0,
            State::new(1.0, 2.0, 0.0),
        )];
        s.seal(0, &mut out);
        let genuine = out[0];
        assert!(genuine.seal.is_some());
        s.begin_step();
        assert!(s.screen(0, &delivery(2, genuine)).is_ok());
        // Altered on the way: the seal stays, the signature no longer holds.
        let mut altered = genuine;
        altered.state[2] = -6.0;
        assert_eq!(
            s.screen(0, &delivery(2, altered)),
            Err(Refusal::BadSignature)
        );
        // Forged from nothing: no seal.
        let forged = Packet::beacon(VehicleId(1), 2, 0, State::new(1.0, 2.0, 0.0));
        assert_eq!(s.screen(0, &delivery(2, forged)), Err(Refusal::Truncated));
        // Signed by a key outside the PKI.
        let mut outsider = Sealing::new(
            SecurityParams {
                seed: 99,
                ..SecurityParams::default()
            },
            3,
            0.01,
        );
        let mut theirs = [forged];
        outsider.seal(0, &mut theirs);
        assert_eq!(
            s.screen(0, &delivery(2, theirs[0])),
            Err(Refusal::ForeignRoot)
        );
        let c = s.counts();
        let by: std::collections::BTreeMap<_, _> = c.by_reason().collect();
        assert_eq!(
            (by["bad_signature"], by["truncated"], by["foreign_root"]),
            (1, 1, 1)
        );
        assert_eq!((c.signed, c.verified, c.refused_total()), (1, 1, 3));
    }

    /// Two platoons of a fleet: one PKI, so each verifies the other's packets, and no vehicle
    /// of one holds a key of the other.
    #[test]
    fn the_platoons_of_a_fleet_share_the_pki_and_not_their_pseudonyms() {
        let of = |platoon| {
            Sealing::new(
                SecurityParams {
                    platoon,
                    ..SecurityParams::default()
                },
                3,
                0.01,
            )
        };
        let (mut first, mut second) = (of(0), of(1));
        assert_eq!(
            first.keys.pki().root().digest(),
            second.keys.pki().root().digest(),
            "one PKI"
        );
        for (a, b) in first.signers.iter().zip(&second.signers) {
            assert_ne!(a.digest(), b.digest());
        }
        for (a, b) in second.signers.iter().zip(&of(1).signers) {
            assert_eq!(a.digest(), b.digest(), "reproducible");
        }
        let mut out = [Packet::beacon(
            VehicleId(1),
            1,
            0,
            State::new(1.0, 2.0, 0.0),
        )];
        second.seal(0, &mut out);
        first.begin_step();
        assert!(first.screen(0, &delivery(2, out[0])).is_ok());
        // Platoon 0's keys are what they were before platoons had their own.
        let before = Sealing::new(SecurityParams::default(), 3, 0.01);
        for (a, b) in first.signers.iter().zip(&before.signers) {
            assert_eq!(a.digest(), b.digest());
        }
    }

    #[test]
    fn on_demand_defers_the_signature_to_the_confirmation() {
        let params = SecurityParams {
            policy: SecurityPolicy::OnDemand,
            ..SecurityParams::default()
        };
        let mut s = Sealing::new(params, 3, 0.01);
        let mut out = [Packet::beacon(
            VehicleId(1),
            1,
            0,
            State::new(1.0, 2.0, 0.0),
        )];
        s.seal(0, &mut out);
        let mut altered = out[0];
        altered.state[0] = 50.0;
        let d = delivery(2, altered);
        assert!(s.screen(0, &d).is_ok(), "the signature waits");
        assert_eq!(s.confirm(0, &d), Err(Refusal::BadSignature));
        assert_eq!(s.counts().refused[6], 1, "bad_signature");
    }

    #[test]
    fn a_pseudonym_change_carries_the_new_certificate() {
        let params = SecurityParams {
            pseudonym_change_ms: 100,
            ..SecurityParams::default()
        };
        let mut s = Sealing::new(params, 2, 0.1);
        for k in 0..5 {
            let mut out = [Packet::beacon(
                VehicleId(0),
                k as u32 + 1,
                k,
                State::new(0.0, 1.0, 0.0),
            )];
            s.seal(k, &mut out);
            let len = out[0].seal.unwrap().as_bytes().len();
            // Every step changes the pseudonym (100 ms): every packet carries its certificate.
            assert_eq!(len, platoon_security::CERTIFICATE_HEADER_LEN, "step {k}");
            s.begin_step();
            assert!(s.screen(k, &delivery(1, out[0])).is_ok(), "step {k}");
        }
    }
}
