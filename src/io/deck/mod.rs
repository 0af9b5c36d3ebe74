//! Input decks (owned by the deck work in progress).
