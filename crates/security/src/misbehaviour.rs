//! Misbehaviour reports and the misbehaviour authority (MA) that decides on them, after ETSI
//! TS 103 759 and SAE J3287, reduced to what a platoon's control loop feels: who reported
//! whom, with which signed packets as evidence, and when the accused's certificates are
//! revoked.
//!
//! - A reporter (a vehicle whose detector flagged a sender) files a [`Report`]: the accused's
//!   pseudonym, the detector, the offending packets as the accused signed them
//!   ([`Evidence`]), and what its radar saw ([`RadarObservation`]). It signs the report with
//!   its own pseudonym ([`SignedReport`]), so nobody files reports in another's name.
//! - Reports travel an [`Uplink`] (a latency and a loss probability, drawn from a seeded RNG)
//!   to the [`Authority`].
//! - The authority knows, as the PKI's enrolment does, which vehicle holds which pseudonym
//!   ([`Authority::enrol`]). It checks each report ([`ReportOutcome`]: the reporter's
//!   signature, the evidence's signatures under the accused's key) and decides by
//!   [`AuthorityRule`]: a vehicle is revoked once reports with verified evidence from
//!   `quorum` distinct vehicles other than itself, none of them revoked, arrived within
//!   `window_ms`. Distinct vehicles, not pseudonyms: a Sybil's or a pseudonym changer's
//!   reports count once. Its [`Revocation`] names every pseudonym the vehicle was enrolled
//!   with, which receivers put on their revocation lists ([`crate::Verifier::revoke`]).
//!
//! What the rule protects against, and what not: one insider reporting an honest member, with
//! as many pseudonyms as it likes, never reaches a quorum of two; `quorum` colluding
//! insiders do. The evidence's signatures prove the accused sent those packets, not that they
//! lie: whether they contradict the physics is the reporters' judgement (the authority does
//! not re-run their detectors), which is why the rule asks for several.
//!
//! Pure: times are the run's (ms), passed in; the uplink's losses come from its own seeded
//! RNG; two authorities fed the same reports in the same order decide the same.

use crate::ecdsa::PublicKey;
use crate::{CertKind, Certificate, HashedId8, Refusal, SecurityHeader, Signer};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// A vehicle's long-term identity, which the PKI's enrolment links its pseudonyms to (the
/// simulation's vehicle id).
pub type VehicleKey = u32;

/// A packet as its sender signed it: the payload and its security header.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence {
    /// The packet's payload bytes.
    pub payload: Vec<u8>,
    /// The header the sender attached.
    pub header: SecurityHeader,
}

/// What the reporter's radar measured of the vehicle ahead when it flagged the accused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarObservation {
    /// When (ms of the run's time).
    pub at_ms: u64,
    /// The gap to the vehicle ahead (m).
    pub gap_m: f64,
    /// The vehicle ahead's speed less the reporter's (m/s).
    pub relative_speed_mps: f64,
}

/// A misbehaviour report, before the reporter signs it.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The accused's pseudonym (its certificate digest).
    pub accused: HashedId8,
    /// Which detector flagged it (the caller's code, carried as is).
    pub detector: u8,
    /// When the reporter filed it (ms).
    pub filed_ms: u64,
    /// The offending packets, as the accused signed them.
    pub evidence: Vec<Evidence>,
    /// What the reporter's radar saw, if it sees the accused.
    pub observed: Option<RadarObservation>,
}

impl Report {
    /// The bytes the reporter signs: every field in a fixed order, lengths before contents.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(32 + self.evidence.len() * 300);
        out.extend_from_slice(&self.accused.0);
        out.push(self.detector);
        out.extend_from_slice(&self.filed_ms.to_be_bytes());
        out.extend_from_slice(&(self.evidence.len() as u32).to_be_bytes());
        for e in &self.evidence {
            out.extend_from_slice(&(e.payload.len() as u32).to_be_bytes());
            out.extend_from_slice(&e.payload);
            let header = e.header.to_bytes();
            out.extend_from_slice(&(header.len() as u32).to_be_bytes());
            out.extend_from_slice(&header);
        }
        match &self.observed {
            None => out.push(0),
            Some(o) => {
                out.push(1);
                out.extend_from_slice(&o.at_ms.to_be_bytes());
                out.extend_from_slice(&o.gap_m.to_be_bytes());
                out.extend_from_slice(&o.relative_speed_mps.to_be_bytes());
            }
        }
        out
    }

    /// The report signed by `reporter` at `now_ms` (with its certificate's digest: the
    /// authority knows every enrolled pseudonym).
    pub fn sign(self, reporter: &Signer, now_ms: u64) -> SignedReport {
        let header = reporter.sign_with(&self.encode(), now_ms, false);
        SignedReport {
            report: self,
            header,
        }
    }
}

/// A report and its reporter's signature.
#[derive(Debug, Clone, PartialEq)]
pub struct SignedReport {
    /// What it says.
    pub report: Report,
    /// The reporter's security header over [`Report::encode`].
    pub header: SecurityHeader,
}

impl SignedReport {
    /// The reporter's pseudonym.
    pub fn reporter(&self) -> HashedId8 {
        self.header.signer.digest()
    }
}

/// What the authority made of one report. Each has a stable [`name`](ReportOutcome::name)
/// for a dataset's column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReportOutcome {
    /// Its reporter signed it and its evidence is the accused's: it counts towards the rule.
    Counted,
    /// The reporter's pseudonym is not enrolled (an outsider's report).
    UnknownReporter,
    /// The report's signature does not verify under the reporter's key (why).
    BadReportSignature(Refusal),
    /// The accused's pseudonym is not enrolled.
    UnknownAccused,
    /// It carries no evidence.
    NoEvidence,
    /// A piece of evidence was not signed by the accused, or its signature does not verify
    /// (why): a forged or altered packet proves nothing against the accused.
    BadEvidence(Refusal),
    /// Reporter and accused are the same vehicle (under two pseudonyms).
    SelfReport,
    /// The reporter's vehicle is revoked: its reports no longer count.
    RevokedReporter,
    /// The accused's vehicle is revoked already.
    AlreadyRevoked,
}

impl ReportOutcome {
    /// Every outcome's name, in code order (code 1 first).
    pub const NAMES: [&'static str; 9] = [
        "counted",
        "unknown_reporter",
        "bad_report_signature",
        "unknown_accused",
        "no_evidence",
        "bad_evidence",
        "self_report",
        "revoked_reporter",
        "already_revoked",
    ];

    /// A stable code, 1 to 9, in the order of [`ReportOutcome::NAMES`].
    pub fn code(self) -> u8 {
        match self {
            ReportOutcome::Counted => 1,
            ReportOutcome::UnknownReporter => 2,
            ReportOutcome::BadReportSignature(_) => 3,
            ReportOutcome::UnknownAccused => 4,
            ReportOutcome::NoEvidence => 5,
            ReportOutcome::BadEvidence(_) => 6,
            ReportOutcome::SelfReport => 7,
            ReportOutcome::RevokedReporter => 8,
            ReportOutcome::AlreadyRevoked => 9,
        }
    }

    /// A stable snake_case name.
    pub fn name(self) -> &'static str {
        match self {
            ReportOutcome::Counted => "counted",
            ReportOutcome::UnknownReporter => "unknown_reporter",
            ReportOutcome::BadReportSignature(_) => "bad_report_signature",
            ReportOutcome::UnknownAccused => "unknown_accused",
            ReportOutcome::NoEvidence => "no_evidence",
            ReportOutcome::BadEvidence(_) => "bad_evidence",
            ReportOutcome::SelfReport => "self_report",
            ReportOutcome::RevokedReporter => "revoked_reporter",
            ReportOutcome::AlreadyRevoked => "already_revoked",
        }
    }
}

/// The authority's decision rule (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AuthorityRule {
    /// How many distinct vehicles (other than the accused) must report it.
    pub quorum: usize,
    /// Within how long of each other their counted reports must arrive (ms).
    pub window_ms: u64,
}

impl Default for AuthorityRule {
    /// Two reporters within 5 s: the smallest quorum a lone liar cannot reach, over a window
    /// long enough for the followers behind an attacker to flag it one after the other.
    fn default() -> Self {
        AuthorityRule {
            quorum: 2,
            window_ms: 5000,
        }
    }
}

/// A vehicle the authority revoked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Revocation {
    /// Whom.
    pub vehicle: VehicleKey,
    /// Every pseudonym it was enrolled with, for the receivers' revocation lists.
    pub pseudonyms: Vec<HashedId8>,
    /// When the authority decided (ms): the arrival of the report that completed the quorum.
    pub decided_ms: u64,
    /// The vehicles whose reports made the quorum, in the order they arrived.
    pub reporters: Vec<VehicleKey>,
}

#[derive(Debug, Clone, Copy)]
struct Enrolled {
    vehicle: VehicleKey,
    key: PublicKey,
    cert: Certificate,
}

/// The misbehaviour authority (module docs).
#[derive(Debug, Clone)]
pub struct Authority {
    rule: AuthorityRule,
    issuer: HashedId8,
    issuer_key: PublicKey,
    enrolled: BTreeMap<HashedId8, Enrolled>,
    /// Per accused vehicle, its counted reports: (arrival ms, reporting vehicle).
    counted: BTreeMap<VehicleKey, Vec<(u64, VehicleKey)>>,
    revoked: BTreeSet<VehicleKey>,
}

impl Authority {
    /// An authority for the pseudonyms `authority` (the PKI's authorization authority's
    /// certificate) issues ([`Refusal::WrongKind`] if it is no authority's).
    pub fn new(authority: &Certificate, rule: AuthorityRule) -> Result<Authority, Refusal> {
        if authority.kind != CertKind::Authority {
            return Err(Refusal::WrongKind);
        }
        Ok(Authority {
            rule,
            issuer: authority.digest(),
            issuer_key: authority.public_key()?,
            enrolled: BTreeMap::new(),
            counted: BTreeMap::new(),
            revoked: BTreeSet::new(),
        })
    }

    /// Records that `vehicle` holds the pseudonym `cert` (what the PKI's enrolment knows):
    /// [`Refusal::ForeignRoot`] if another authority issued it,
    /// [`Refusal::BadCertificateSignature`] if its fields were altered.
    pub fn enrol(&mut self, vehicle: VehicleKey, cert: &Certificate) -> Result<(), Refusal> {
        if cert.kind != CertKind::Pseudonym {
            return Err(Refusal::WrongKind);
        }
        if cert.issuer != self.issuer {
            return Err(Refusal::ForeignRoot);
        }
        cert.check_signed_by(&self.issuer_key)?;
        let key = cert.public_key()?;
        self.enrolled.insert(
            cert.digest(),
            Enrolled {
                vehicle,
                key,
                cert: *cert,
            },
        );
        Ok(())
    }

    /// The vehicle enrolled with `pseudonym`.
    pub fn vehicle_of(&self, pseudonym: HashedId8) -> Option<VehicleKey> {
        self.enrolled.get(&pseudonym).map(|e| e.vehicle)
    }

    /// Whether `vehicle` is revoked.
    pub fn is_revoked(&self, vehicle: VehicleKey) -> bool {
        self.revoked.contains(&vehicle)
    }

    /// Takes `report`, arrived at `now_ms`: what it made of it and, if the report completed a
    /// quorum, the revocation it decided.
    pub fn receive(
        &mut self,
        report: &SignedReport,
        now_ms: u64,
    ) -> (ReportOutcome, Option<Revocation>) {
        let (reporter, accused) = match self.check(report) {
            Ok(pair) => pair,
            Err(outcome) => return (outcome, None),
        };
        let window = self.rule.window_ms;
        let counted = self.counted.entry(accused).or_default();
        counted.push((now_ms, reporter));
        counted.retain(|(at, _)| now_ms.saturating_sub(*at) <= window);
        // Each reporting vehicle once, in the order of its first counted report in the window.
        let mut reporters: Vec<VehicleKey> = Vec::new();
        for (_, v) in counted.iter() {
            if !reporters.contains(v) && !self.revoked.contains(v) {
                reporters.push(*v);
            }
        }
        if reporters.len() < self.rule.quorum {
            return (ReportOutcome::Counted, None);
        }
        self.revoked.insert(accused);
        self.counted.remove(&accused);
        let pseudonyms = self
            .enrolled
            .iter()
            .filter(|(_, e)| e.vehicle == accused)
            .map(|(d, _)| *d)
            .collect();
        let revocation = Revocation {
            vehicle: accused,
            pseudonyms,
            decided_ms: now_ms,
            reporters,
        };
        (ReportOutcome::Counted, Some(revocation))
    }

    /// The report's reporter and accused vehicles, once it may count.
    fn check(&self, report: &SignedReport) -> Result<(VehicleKey, VehicleKey), ReportOutcome> {
        let reporter = self
            .enrolled
            .get(&report.reporter())
            .ok_or(ReportOutcome::UnknownReporter)?;
        verify(reporter, &report.report.encode(), &report.header)
            .map_err(ReportOutcome::BadReportSignature)?;
        let accused = self
            .enrolled
            .get(&report.report.accused)
            .ok_or(ReportOutcome::UnknownAccused)?;
        if report.report.evidence.is_empty() {
            return Err(ReportOutcome::NoEvidence);
        }
        for e in &report.report.evidence {
            if e.header.signer.digest() != report.report.accused {
                return Err(ReportOutcome::BadEvidence(Refusal::BadSignature));
            }
            verify(accused, &e.payload, &e.header).map_err(ReportOutcome::BadEvidence)?;
        }
        if reporter.vehicle == accused.vehicle {
            return Err(ReportOutcome::SelfReport);
        }
        if self.revoked.contains(&reporter.vehicle) {
            return Err(ReportOutcome::RevokedReporter);
        }
        if self.revoked.contains(&accused.vehicle) {
            return Err(ReportOutcome::AlreadyRevoked);
        }
        Ok((reporter.vehicle, accused.vehicle))
    }
}

/// `header`'s signature over `payload` under `signer`'s key, and its certificate valid when
/// it was signed (reports and evidence arrive later than packets: freshness is not asked).
fn verify(signer: &Enrolled, payload: &[u8], header: &SecurityHeader) -> Result<(), Refusal> {
    signer.cert.validity.check(header.generated_ms)?;
    let message = SecurityHeader::signed_message(payload, header.generated_ms, &header.signer);
    if signer.key.verifies(&message, &header.signature) {
        Ok(())
    } else {
        Err(Refusal::BadSignature)
    }
}

/// The reporters' uplink to the authority: each report arrives `latency_ms` after it was
/// sent, or is lost with probability `loss` (drawn from the uplink's own seeded RNG, one
/// draw per report sent, so the same sends lose the same reports).
#[derive(Debug, Clone)]
pub struct Uplink {
    latency_ms: u64,
    loss: f64,
    rng: ChaCha8Rng,
    queue: VecDeque<(u64, SignedReport)>,
    lost: u64,
}

impl Uplink {
    /// An uplink of `latency_ms` that loses a report with probability `loss` (clamped to
    /// [0, 1]), its draws from `seed`.
    pub fn new(latency_ms: u64, loss: f64, seed: u64) -> Uplink {
        Uplink {
            latency_ms,
            loss: if loss.is_nan() {
                0.0
            } else {
                loss.clamp(0.0, 1.0)
            },
            rng: ChaCha8Rng::seed_from_u64(seed),
            queue: VecDeque::new(),
            lost: 0,
        }
    }

    /// Sends `report` at `now_ms`; whether it will arrive (false: lost).
    pub fn send(&mut self, report: SignedReport, now_ms: u64) -> bool {
        let draw: f64 = self.rng.gen();
        if draw < self.loss {
            self.lost += 1;
            return false;
        }
        let at = now_ms.saturating_add(self.latency_ms);
        // Sends come in time order, so the queue stays sorted by arrival.
        self.queue.push_back((at, report));
        true
    }

    /// The reports that have arrived by `now_ms`, in the order they were sent.
    pub fn arrivals(&mut self, now_ms: u64) -> Vec<(u64, SignedReport)> {
        let mut out = Vec::new();
        while self.queue.front().is_some_and(|(at, _)| *at <= now_ms) {
            out.extend(self.queue.pop_front());
        }
        out
    }

    /// How many reports it lost so far.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// How many reports are on their way.
    pub fn in_flight(&self) -> usize {
        self.queue.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AttachRule, Pki, Validity};

    struct World {
        pki: Pki,
        rng: ChaCha8Rng,
        authority: Authority,
    }

    const VALID: Validity = Validity {
        from_ms: 0,
        until_ms: 3_600_000,
    };

    impl World {
        fn new(rule: AuthorityRule) -> World {
            let mut rng = ChaCha8Rng::seed_from_u64(52);
            let pki = Pki::generate(&mut rng, VALID);
            let authority = Authority::new(pki.authority().certificate(), rule).unwrap();
            World {
                pki,
                rng,
                authority,
            }
        }

        /// A pseudonym for `vehicle`, enrolled.
        fn member(&mut self, vehicle: VehicleKey) -> Signer {
            let p = self.pki.pseudonym(&mut self.rng, VALID);
            self.authority.enrol(vehicle, p.certificate()).unwrap();
            Signer::new(p, AttachRule::STANDARD)
        }
    }

    /// A packet `sender` signed at `t_ms`.
    fn packet(sender: &Signer, t_ms: u64, speed: f64) -> Evidence {
        let payload = speed.to_be_bytes().to_vec();
        let header = sender.sign_with(&payload, t_ms, false);
        Evidence { payload, header }
    }

    fn report(by: &Signer, accused: &Signer, t_ms: u64) -> SignedReport {
        Report {
            accused: accused.digest(),
            detector: 1,
            filed_ms: t_ms,
            evidence: vec![packet(accused, t_ms - 100, 30.0)],
            observed: Some(RadarObservation {
                at_ms: t_ms - 100,
                gap_m: 12.0,
                relative_speed_mps: -1.5,
            }),
        }
        .sign(by, t_ms)
    }

    #[test]
    fn two_reporters_revoke_every_pseudonym_of_the_accused() {
        let mut w = World::new(AuthorityRule::default());
        let liar = w.member(2);
        let liar_again = w.member(2);
        let (f3, f4) = (w.member(3), w.member(4));
        let (outcome, none) = w.authority.receive(&report(&f3, &liar, 10_000), 10_050);
        assert_eq!((outcome, none), (ReportOutcome::Counted, None));
        // The same reporter again, under the same pseudonym: still one vehicle.
        let (_, none) = w.authority.receive(&report(&f3, &liar, 10_200), 10_250);
        assert_eq!(none, None);
        let (outcome, revocation) = w.authority.receive(&report(&f4, &liar, 11_000), 11_050);
        assert_eq!(outcome, ReportOutcome::Counted);
        let revocation = revocation.expect("two vehicles reported it");
        assert_eq!(revocation.vehicle, 2);
        assert_eq!(revocation.decided_ms, 11_050);
        assert_eq!(revocation.reporters, vec![3, 4]);
        let mut both = vec![liar.digest(), liar_again.digest()];
        both.sort();
        assert_eq!(revocation.pseudonyms, both);
        assert!(w.authority.is_revoked(2));
        // A later report against it changes nothing; the revoked vehicle's reports stop counting.
        let (outcome, _) = w
            .authority
            .receive(&report(&f4, &liar_again, 12_000), 12_050);
        assert_eq!(outcome, ReportOutcome::AlreadyRevoked);
        let (outcome, _) = w.authority.receive(&report(&liar, &f3, 12_000), 12_050);
        assert_eq!(outcome, ReportOutcome::RevokedReporter);
    }

    #[test]
    fn one_insider_with_many_pseudonyms_never_revokes_an_honest_member() {
        let mut w = World::new(AuthorityRule::default());
        let honest = w.member(1);
        // The insider reports with a fresh pseudonym each time (a Sybil of itself), the
        // honest member's genuine packets as its evidence.
        for i in 0..20u64 {
            let sybil = w.member(3);
            let t = 10_000 + i * 100;
            let (outcome, revocation) = w.authority.receive(&report(&sybil, &honest, t), t);
            assert_eq!(outcome, ReportOutcome::Counted);
            assert_eq!(revocation, None, "report {i}");
        }
        assert!(!w.authority.is_revoked(1));
        // Reporting itself under another pseudonym does not count either.
        let other = w.member(1);
        let (outcome, _) = w
            .authority
            .receive(&report(&other, &honest, 13_000), 13_000);
        assert_eq!(outcome, ReportOutcome::SelfReport);
    }

    #[test]
    fn reports_further_apart_than_the_window_do_not_make_a_quorum() {
        let mut w = World::new(AuthorityRule {
            quorum: 2,
            window_ms: 1000,
        });
        let liar = w.member(2);
        let (f3, f4) = (w.member(3), w.member(4));
        assert_eq!(
            w.authority.receive(&report(&f3, &liar, 10_000), 10_000).1,
            None
        );
        assert_eq!(
            w.authority.receive(&report(&f4, &liar, 11_500), 11_500).1,
            None
        );
        let revocation = w.authority.receive(&report(&f3, &liar, 12_000), 12_000).1;
        assert_eq!(revocation.map(|r| r.reporters), Some(vec![4, 3]));
    }

    #[test]
    fn forged_or_foreign_reports_and_evidence_do_not_count() {
        let mut w = World::new(AuthorityRule::default());
        let accused = w.member(2);
        let f3 = w.member(3);
        // An outsider: a pseudonym of another PKI.
        let mut other_rng = ChaCha8Rng::seed_from_u64(7);
        let other = Pki::generate(&mut other_rng, VALID);
        let outsider = Signer::new(other.pseudonym(&mut other_rng, VALID), AttachRule::STANDARD);
        assert_eq!(
            w.authority.enrol(9, outsider.certificate()),
            Err(Refusal::ForeignRoot)
        );
        let (o, _) = w
            .authority
            .receive(&report(&outsider, &accused, 10_000), 10_000);
        assert_eq!(o, ReportOutcome::UnknownReporter);
        // A report altered after signing.
        let mut altered = report(&f3, &accused, 10_000);
        altered.report.detector = 2;
        let (o, _) = w.authority.receive(&altered, 10_000);
        assert_eq!(o, ReportOutcome::BadReportSignature(Refusal::BadSignature));
        // Evidence the accused never signed: altered, or signed by someone else.
        let mut r = report(&f3, &accused, 10_000).report;
        r.evidence[0].payload = 50.0f64.to_be_bytes().to_vec();
        let (o, _) = w.authority.receive(&r.sign(&f3, 10_000), 10_000);
        assert_eq!(o, ReportOutcome::BadEvidence(Refusal::BadSignature));
        let mut r = report(&f3, &accused, 10_000).report;
        r.evidence[0] = packet(&f3, 9_900, 30.0);
        let (o, _) = w.authority.receive(&r.sign(&f3, 10_000), 10_000);
        assert_eq!(o, ReportOutcome::BadEvidence(Refusal::BadSignature));
        let mut r = report(&f3, &accused, 10_000).report;
        r.evidence.clear();
        assert_eq!(
            w.authority.receive(&r.sign(&f3, 10_000), 10_000).0,
            ReportOutcome::NoEvidence
        );
        let mut r = report(&f3, &accused, 10_000).report;
        r.accused = outsider.digest();
        assert_eq!(
            w.authority.receive(&r.sign(&f3, 10_000), 10_000).0,
            ReportOutcome::UnknownAccused
        );
        // None of them counted: one honest report is still short of the quorum.
        assert_eq!(
            w.authority
                .receive(&report(&f3, &accused, 10_500), 10_500)
                .1,
            None
        );
    }

    #[test]
    fn every_outcome_has_its_code_and_name_in_order() {
        let all = [
            ReportOutcome::Counted,
            ReportOutcome::UnknownReporter,
            ReportOutcome::BadReportSignature(Refusal::BadSignature),
            ReportOutcome::UnknownAccused,
            ReportOutcome::NoEvidence,
            ReportOutcome::BadEvidence(Refusal::BadSignature),
            ReportOutcome::SelfReport,
            ReportOutcome::RevokedReporter,
            ReportOutcome::AlreadyRevoked,
        ];
        for (i, o) in all.iter().enumerate() {
            assert_eq!(usize::from(o.code()), i + 1);
            assert_eq!(ReportOutcome::NAMES[i], o.name());
        }
    }

    #[test]
    fn the_uplink_delays_and_loses_reproducibly() {
        let mut w = World::new(AuthorityRule::default());
        let (a, b) = (w.member(1), w.member(2));
        let sends = |loss: f64| {
            let mut up = Uplink::new(300, loss, 11);
            let sent: Vec<bool> = (0..200u64)
                .map(|i| up.send(report(&a, &b, 1_000 + i), 1_000 + i))
                .collect();
            (up, sent)
        };
        let (mut up, sent) = sends(0.25);
        let (_, again) = sends(0.25);
        assert_eq!(sent, again, "the same draws");
        let delivered = sent.iter().filter(|s| **s).count();
        assert!(
            (120..=180).contains(&delivered),
            "{delivered} of 200 at 25 % loss"
        );
        assert_eq!(up.lost() as usize, 200 - delivered);
        assert!(up.arrivals(1_299).is_empty(), "nothing before the latency");
        let first = up.arrivals(1_300);
        assert_eq!(first.len(), usize::from(sent[0]));
        let rest = up.arrivals(u64::MAX);
        assert_eq!(first.len() + rest.len(), delivered);
        assert!(rest.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(up.in_flight(), 0);
        let (_, none_lost) = sends(0.0);
        assert!(none_lost.iter().all(|s| *s));
        let (_, all_lost) = sends(1.0);
        assert!(all_lost.iter().all(|s| !*s));
    }
}
