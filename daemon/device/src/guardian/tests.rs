use super::*;

#[test]
fn zero_current_is_all_zero_d_a_values_in_each_protocol() {
    let (endpoint, sh4_zero) = zero_current(Protocol::Sh4);
    assert_eq!(endpoint, sh4::ENDPOINT_OUT);
    assert_eq!(sh4::Command::decode(&sh4_zero).unwrap().dac, [0; CHANNELS]);
    let (endpoint, simple_zero) = zero_current(Protocol::Simple);
    assert_eq!(endpoint, simple::ENDPOINT_OUT);
    let packet: &[u8; simple::PACKET] = simple_zero.as_slice().try_into().unwrap();
    assert_eq!(
        simple::Command::decode(packet),
        Some(simple::Command::SetDac([0; CHANNELS]))
    );
}

#[test]
fn a_greeting_must_come_from_the_process_it_names() {
    let (beats, _) = sealed("test-beats", size_of::<Beat>() * BEAT_SLOTS).unwrap();
    let me = std::process::id() as libc::pid_t;
    let mut other = Command::new("sleep").arg("5").spawn().unwrap();
    let greet = |pid: libc::pid_t, of: libc::pid_t| {
        let (ours, theirs) = socket::pair().unwrap();
        let mut hello = vec![Verb::Hello as u8];
        hello.extend((pid as u32).to_le_bytes());
        let pidfd = pidfd_open(of).unwrap();
        socket::send(&ours, &hello, &[pidfd.as_raw_fd(), beats.as_raw_fd()]).unwrap();
        Daemon::greeted(theirs.as_raw_fd()).map(|d| d.pid)
    };
    assert_eq!(greet(me, me).unwrap(), me);
    let other_pid = other.id() as libc::pid_t;
    for (pid, of) in [(other_pid, other_pid), (me, other_pid), (other_pid, me)] {
        let refused = greet(pid, of).unwrap_err();
        assert!(
            matches!(refused, GreetingError::Impostor { named, peer: _ } if named == pid),
            "{refused}"
        );
    }
    other.kill().unwrap();
    other.wait().unwrap();
    let (ours, theirs) = socket::pair().unwrap();
    socket::send(&ours, &[Verb::Disarm as u8], &[]).unwrap();
    assert!(matches!(
        Daemon::greeted(theirs.as_raw_fd()),
        Err(GreetingError::NotAGreeting)
    ));
}

#[test]
fn messages_round_trip_through_the_guardian_s_reading() {
    let dir = std::env::temp_dir().join(format!("guardian-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let recording = dir.join("session.traffic");
    std::fs::write(&recording, crate::replay::MAGIC).unwrap();
    let mut slots = BTreeMap::new();
    // The recording comes open: the guardian never needs to reach its path.
    let open = std::fs::OpenOptions::new()
        .append(true)
        .open(&recording)
        .unwrap();
    let told = message(Verb::Recording, 7, Protocol::Simple, Path::new("/nowhere"));
    assert!(!apply(&told, vec![open.into()], &mut slots));
    let (protocol, path, _) = slots[&7].recording.as_ref().unwrap();
    assert_eq!(
        (*protocol, path.as_path()),
        (Protocol::Simple, Path::new("/nowhere"))
    );
    assert!(apply(&[Verb::Disarm as u8], Vec::new(), &mut slots));
    zero_everything(0, slots);
    let transfers: Vec<_> = crate::replay::Recording::read(&recording)
        .unwrap()
        .transfers()
        .map(|(d, bytes)| (d, bytes.to_vec()))
        .collect();
    assert_eq!(
        transfers,
        [(Direction::Out, zero_current(Protocol::Simple).1)]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
