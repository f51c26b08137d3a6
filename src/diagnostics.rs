//! Energy and strain measures shared by every backend.
