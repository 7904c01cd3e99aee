//! SSH access to a Power PMAC card, as its users connect: a login shell that behaves as the
//! controller's Linux shell as far as host tools need ([`shell`], pure), served by russh
//! ([`server`]), with sshd's defences against password guessing ([`penalty`], pure).

pub(crate) mod penalty;
pub(crate) mod server;
pub(crate) mod shell;
