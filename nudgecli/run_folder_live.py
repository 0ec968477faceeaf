"""What marks a run folder as a ``nudge study`` (live) folder, and what its reader is told of it.

A live folder holds a real person's trials, which no command can make again: :class:`LiveRecord`
(a base of :class:`nudgecli.run_folder_record.RunRecord`) finds its signs even without a readable
manifest, refuses to simulate into it, and names how to continue or restore it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from nudgecli.command_defaults import STUDY_PORT
from nudgecli.errors import RunFolderError, shell_words
from nudgecli.run_folder_names import CONFIG, LAYOUTS, MANIFEST, PART_KINDS, QUESTIONNAIRES_CSV
from nudgecli.run_folder_state import RUN_OWN, refuse_links
from nudgecli.sim.counterbalance import recorded_order_choice

#: The executor a ``nudge study`` folder's manifest records.
LIVE_EXECUTOR = "live"
#: The key of an analysis's ``stats.json`` recording the trials of a ``nudge study`` folder it saw.
ANALYSED_TRIALS = "live_completed_trials"
#: What ``nudge study`` writes in its folder: a link in their place is refused
#: (:meth:`LiveRecord.refuse_live_links`).
LIVE_OWN = (*RUN_OWN, QUESTIONNAIRES_CSV)
#: What ``nudge study`` leaves in its folder beside the parts: a participant's lock and page token,
#: answers it could not add to questionnaires.csv.
_PARTICIPANT_FILES = (".nudge-participant-*", "questionnaires-unsaved-*.csv")


def _recorded_live(part: Path) -> bool:
    """Whether a participants part records a live session (its ``source`` is ``live``)."""
    from nudgecli.parquet_reader import read_parquet

    try:
        return bool((read_parquet(part.read_bytes(), ["source"])["source"] == LIVE_EXECUTOR).any())
    except Exception:  # an unreadable part, or one without the column: no sign
        return False


class LiveRecord:
    """The live-study side of a run folder (``path``): its signs, the refusal to simulate into it,
    and the hints that continue a session or restore its files."""

    path: Path

    @staticmethod
    def study_under_way(manifest: Mapping[str, Any] | None) -> bool:
        """Whether ``manifest`` is a ``nudge study`` folder's whose study is still under way (analysed
        as far as it got)."""
        return manifest is not None and manifest.get("executor") == LIVE_EXECUTOR and \
            manifest.get("status") != "complete"

    @staticmethod
    def resume_port(entry: Mapping[str, Any]) -> int | None:
        """The ``--port`` a command that continues a participant's session names: the port their page
        was last served on (their manifest entry's ``port``), as the open tab reconnects only there;
        ``None`` for the default port (the command leaves it out) or an entry that records none."""
        port = entry.get("port")
        return port if isinstance(port, int) and not isinstance(port, bool) and port != STUDY_PORT else None

    def live_signs(self) -> list[str]:
        """What shows the folder holds a live study, found without reading its manifest as JSON:
        ``questionnaires.csv`` (the answers ``nudge study`` records), a participant's lock or page
        token, a manifest (even a damaged one) that names the executor ``live``, a participants part
        recorded live (the first only); empty for none."""
        signs = [QUESTIONNAIRES_CSV] if (self.path / QUESTIONNAIRES_CSV).is_file() else []
        for pattern in _PARTICIPANT_FILES:
            signs += sorted(p.name for p in self.path.glob(pattern))[:2]
        try:
            text = (self.path / MANIFEST).read_bytes()
        except OSError:
            text = b""
        if b'"executor": "live"' in text:
            signs.append(f"{MANIFEST} naming the executor live")
        first = next(iter(sorted((self.path / "participants").glob("part-*.parquet"))), None)
        if first is not None and _recorded_live(first):
            signs.append(f"participants/{first.name} of a live session")
        return signs

    @staticmethod
    def analysed_progress(manifest: Mapping[str, Any] | None) -> dict[str, Any]:
        """What an analysis of a ``nudge study`` folder records in its ``stats.json`` of how far the
        study had got (:data:`ANALYSED_TRIALS`: participant -> the trials its manifest listed), so
        ``plot`` can tell an analysis the study has outgrown; empty for any other source."""
        if manifest is None or manifest.get("executor") != LIVE_EXECUTOR:
            return {}
        entries = manifest.get("live") or {}
        return {ANALYSED_TRIALS: {str(key): sorted(int(t) for t in entries[key].get("completed_trials") or [])
                                  for key in sorted(entries, key=int)}}

    def is_live(self, manifest: Mapping[str, Any] | None) -> bool:
        """Whether the folder holds a live study: its ``manifest`` says so, or (without one) its signs."""
        if manifest is not None:
            return manifest.get("executor") == LIVE_EXECUTOR
        return bool(self.live_signs())

    def restore_manifest_advice(self) -> str:
        """What the reader of a live folder whose manifest is lost or damaged is told to do (never
        to simulate again: that would replace the person's trials with simulated ones)."""
        return (f"it holds a live study ({', '.join(self.live_signs())}): put {MANIFEST} back from a copy "
                "(a person's trials cannot be simulated again; never simulate into this folder)")

    def live_parts(self, manifest: Mapping[str, Any]) -> dict[int, list[str]]:
        """Participant -> the part kinds a ``nudge study`` folder's manifest promises: the trials and
        steps of one with recorded trials (rewritten after each), the participants part of one finished."""
        expected: dict[int, list[str]] = {}
        for key, entry in (manifest.get("live") or {}).items():
            kinds = [kind for kind in PART_KINDS
                     if kind != "participants" or entry.get("status") == "complete"]
            expected[int(key)] = kinds if entry.get("completed_trials") else \
                [kind for kind in kinds if kind == "participants"]
        return expected

    def live_part_fix(self, manifest: Mapping[str, Any], part: Path) -> str:
        """What brings back a live folder's ``part`` that disagrees with the manifest: the session's
        resume where the part is the one a checkpoint noted before renaming it into place (it stopped
        before the manifest listed the trial: the resume writes the part again without it), else a
        backup (a person's trial cannot be run again)."""
        from nudgecli.live.record_checks import WRITING  # a checkpoint's record of the parts it renames
        from nudgecli.run_folder_record import file_sha256  # run_folder_record builds on this module

        index = int(part.stem.split("-")[1])
        writing = ((manifest.get("live") or {}).get(str(index)) or {}).get(WRITING) or {}
        if part.is_file() and writing.get(part.parent.name) == file_sha256(part):
            hint = self.continue_session_hint(manifest, [index])
            return f"the session stopped while recording a trial; {hint}"
        return self.restore_from_backup([f"{part.parent.name}/{part.name}"])

    def check_live_trials(self, manifest: Mapping[str, Any]) -> None:
        """Refuse a participant's trials or steps part that holds other trials than the manifest's
        ``completed_trials`` of them (the trials that count), so a reader analyses exactly the trials
        the manifest lists, as a resume continues after exactly them: a part a session renamed into
        place before the manifest listed its trial (the participant's first trial included, whose
        part has no SHA-256 recorded yet), a part changed since written, a manifest edited by hand.

        Raises
        ------
        RunFolderError
            Naming the part, the trials and the fix (:meth:`live_part_fix`).
        """
        from nudgecli.live.record_checks import trial_parts

        for key, entry in sorted((manifest.get("live") or {}).items(), key=lambda item: int(item[0])):
            who = f"participant {entry.get('participant_id', key)}"
            for part in trial_parts(self.path, manifest, int(key), entry, ["trial"]):
                if part.digest is None:
                    continue  # a missing part is named by the check of the parts the manifest promises
                name, where = part.name, part.path
                # the part the manifest vouches for: its list of trials is what disagrees (edited)
                fix = self.restore_from_backup([MANIFEST]) if part.recorded == part.digest else None
                if part.recorded is not None and part.digest != part.recorded:
                    raise RunFolderError(f"{self.path}: {name} changed since it was written (its SHA-256 "
                                         f"differs from the one in the manifest); "
                                         f"{self.live_part_fix(manifest, where)}")
                if part.frame is None:  # pyarrow raises several types for broken files: the part's reader's
                    continue
                if extra := part.extra:
                    raise RunFolderError(f"{self.path}: {name} holds trial(s) {', '.join(map(str, extra))} "
                                         f"of {who}, which the manifest does not list among their recorded "
                                         f"trials; {fix or self.live_part_fix(manifest, where)}")
                if lacking := part.lacking:
                    raise RunFolderError(f"{self.path}: {name} holds no rows of trial(s) "
                                         f"{', '.join(map(str, lacking))}, which the manifest lists as "
                                         f"recorded by {who}; {fix or self.live_part_fix(manifest, where)}")

    def restore_from_backup(self, names: Sequence[str]) -> str:
        """The advice for a live folder's lost or damaged part (or file): a person's trial cannot be
        run again, so only a backup brings it back."""
        return (f"restore {' and '.join(names)} from a backup of {self.path}: a person's trials cannot be "
                "run again (neither nudge study --resume nor a simulation brings a part back)")

    def rebuild_layouts_hint(self, manifest: Mapping[str, Any]) -> str:
        """How a live folder's lost or damaged ``layouts.parquet`` is written again: the layouts follow
        from the experiment and its seed alone, so a one-participant simulation elsewhere writes
        the same file, byte for byte."""
        scratch = self.path.with_name(f"{self.path.name}-layouts")
        seed = manifest.get("seed")
        command = shell_words(["nudge", "simulate", str(self.path / CONFIG), "--participants", "1",
                               *(["--seed", str(seed)] if isinstance(seed, int) else []),
                               "--out", str(scratch)])
        return (f"restore it from a backup, or write it again (the layouts follow from the experiment and "
                f"its seed alone): `{command}`, then copy {scratch / LAYOUTS} into {self.path}")

    def refuse_live_links(self) -> None:
        """Refuse a ``nudge study`` folder where a part folder, ``calibration/``, ``questionnaires.csv``
        or another file it writes (:data:`LIVE_OWN`) is a symbolic link: a person's sessions would be
        written through it into another folder (:func:`~nudgecli.run_folder_state.refuse_links`)."""
        refuse_links(self.path, LIVE_OWN)

    def refuse_live_sessions(self, manifest: Mapping[str, Any] | None, what: str = "simulate") -> None:
        """Refuse to simulate into a ``nudge study`` folder (its manifest's executor is ``live``; with
        no manifest, :meth:`live_signs`): it holds a real person's sessions, which ``--force`` would
        delete and ``--resume`` would take over (``nudge study`` refuses a simulated folder the same
        way; ``what``: the writing the refusal sends elsewhere, as a batch's ``write the batch``).

        Raises
        ------
        RunFolderError
            The folder holds live sessions.
        """
        if manifest is not None and manifest.get("executor") == LIVE_EXECUTOR:
            raise RunFolderError(f"{self.path}: holds live sessions of a person (recorded by `nudge study`); "
                                 f"{what} into another --out (neither --resume nor --force applies to them)")
        if manifest is None and (signs := self.live_signs()):
            raise RunFolderError(f"{self.path}: holds a live study of a person ({', '.join(signs)}) and no "
                                 f"readable {MANIFEST}; {what} into another --out (neither --resume nor "
                                 f"--force applies to it), and put {MANIFEST} back from a copy")

    def continue_session_hint(self, manifest: Mapping[str, Any], participants: Iterable[int] = ()) -> str:
        """How to continue a ``nudge study`` folder's session: ``nudge study RUN/config.toml ... --resume``
        (config.toml holds the --set values) with its seed, the ID where one session is meant
        (``participants``, else the one unfinished), ``ID`` otherwise, and a non-default --condition-order
        and --port (:meth:`resume_port`) of the one session."""
        from nudgecli.store import study_resume_command  # store builds on this module

        entries = {str(key): entry for key, entry in (manifest.get("live") or {}).items()
                   if isinstance(entry, Mapping) and entry.get("participant_id")}
        keys = [str(index) for index in participants] or \
            [key for key, entry in entries.items() if entry.get("status") != "complete"]
        orders = {str(entry["participant_id"]): recorded_order_choice(manifest.get("config"), int(key),
                                                                      entry.get("condition_order"))
                  for key, entry in entries.items() if key in keys}  # the --condition-order each needs
        ids = list(orders)
        seed = manifest.get("seed")
        port = self.resume_port(next(e for k, e in entries.items() if k in keys)) if len(ids) == 1 else None
        command = study_resume_command(str(self.path / CONFIG), ids[0] if len(ids) == 1 else "ID", self.path,
                                       port=port, condition_order=orders[ids[0]] if len(ids) == 1 else None,
                                       seed=seed if isinstance(seed, int) else None)
        named = [f"{pid} with --condition-order {orders[pid]}" if orders[pid] else pid for pid in ids]
        among = f" (ID: one of {', '.join(named)})" if len(ids) > 1 else ""
        return f"continue the participant's session with `{command}`{among}"


    def _live_progress_note(self, manifest: Mapping[str, Any]) -> str:
        """How far an unfinished ``nudge study`` folder got: its participants finished, its trials
        recorded (the manifest's ``live`` entries are the truth about both)."""
        entries = dict(manifest.get("live") or {})
        finished = sum(entry.get("status") == "complete" for entry in entries.values())
        done = {key: len(entry.get("completed_trials") or []) for key, entry in entries.items()}
        under_way = ", ".join(f"{entries[key].get('participant_id', key)} with {done[key]} trial(s)"
                              for key in sorted(entries, key=int) if entries[key].get("status") != "complete")
        return (f"{self.path}: a live study still under way: {finished} of {len(entries)} participant(s) "
                f"finished, {sum(done.values())} trial(s) recorded (unfinished: {under_way}); the "
                "statistics are of the trials recorded so far")

