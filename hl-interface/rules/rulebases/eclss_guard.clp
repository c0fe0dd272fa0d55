;;; eclss_guard.clp — the ECLSS alarm handling of seed §3.4/§4.3 (robosim rules, docs/rules.md).
;;;
;;; The plant (`robosim automation --session S`) rings alarms as injected faults propagate
;;; through the ECLSS fault model; they are mirrored as (alarm (source PROCESS) (kind ALARM)
;;; (value T) (message GENERATOR)) facts. On new alarms this rule base
;;;   1. diagnoses them: (robosim diagnose) runs FSPI/FSCI/ILM (the query protocol's
;;;      diag_diagnose) over every ringing alarm and asserts a (diagnosis …) fact;
;;;   2. isolates each faulty component the diagnosis names: its unit is moved from the plant's
;;;      on-line item `eclss` to `eclss_isolated` — one transaction, journaled;
;;;   3. then commands the reconfiguration: the component's spare is moved from `eclss_spares`
;;;      to `eclss` — a second transaction, journaled.
;;; The plant follows the committed model: an isolated component's fault stops propagating, and
;;; once its spare is on line the fault is repaired and its alarms stop ringing.

(deftemplate handled (slot component) (slot isolated) (slot reconfigured))
(deftemplate need-diagnosis)

;;; Any new ECLSS alarm asks for a (new) diagnosis; alarms of one mirror pass ask once.
(defrule eclss-alarm
  (alarm (source ?s&:(eq (str-index "ECLSS" (str-cat ?s)) 1)) (kind ?a) (value ?t))
  =>
  (printout t "eclss_guard: alarm " ?a " (" ?s ") at t = " ?t " s" crlf)
  (assert (need-diagnosis)))

(defrule diagnose
  (declare (salience -10))
  ?n <- (need-diagnosis)
  =>
  (retract ?n)
  (do-for-all-facts ((?d diagnosis)) TRUE (retract ?d))
  (robosim diagnose))

(defrule report-diagnosis
  (diagnosis (failure-modes $?fm) (components $?c) (alarms ?n))
  =>
  (printout t "eclss_guard: " ?n " alarm(s) -> " (implode$ ?fm) " [components: " (implode$ ?c) "]" crlf))

;;; Step 1: isolate — the faulty unit leaves the on-line plant.
(defrule isolate
  (diagnosis (components $? ?c $?))
  (instance (name ?c) (parent eclss))
  (not (handled (component ?c)))
  =>
  (bind ?v (robosim transact (str-cat "[[\"attach\", \"" ?c "\", \"eclss_isolated\"]]")))
  (printout t "eclss_guard: " ?c " isolated at version " ?v crlf)
  (assert (handled (component ?c) (isolated ?v) (reconfigured 0))))

;;; Step 2: reconfigure — the component's spare comes on line, only after the isolation was
;;; acknowledged.
(defrule reconfigure
  ?h <- (handled (component ?c) (isolated ?v&:(> ?v 0)) (reconfigured 0))
  (instance (name ?s&:(eq ?s (sym-cat ?c _spare))) (parent eclss_spares))
  =>
  (bind ?w (robosim transact (str-cat "[[\"attach\", \"" ?s "\", \"eclss\"]]")))
  (printout t "eclss_guard: " ?s " on line at version " ?w crlf)
  (modify ?h (reconfigured ?w)))

(defrule report-errors
  (robosim-error (command ?c) (message ?m))
  =>
  (printout t "eclss_guard: (robosim " ?c ") failed: " ?m crlf))
