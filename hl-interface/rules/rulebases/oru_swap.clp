;;; oru_swap.clp — the servicer's task planned by rules (seed §3.4: "task planning for robotics
;;; applications on the Station"; robosim study station --fault array_oru@T; docs/studies.md).
;;;
;;; Every study step the study retracts its observation facts and asserts them afresh from the
;;; model's state: the time (oru-now), each solar array's power against what the power model
;;; expects at its angles and whether it is parked (oru-array), the servicer — moving or not,
;;; and where its effector is (oru-servicer: rest, site, above-oru, oru, above-stow, stow,
;;; above-spare, spare, between) — and where the two ORUs are (oru-unit: the failed one
;;; on-array | held | set-down, the spare on-truss | held | bolted). Then the rules run:
;;;   1. a guard: an array short of its expected power by more than ?*oru-drop* over
;;;      ?*oru-persist* sunlit steps in a row has a failed power-system ORU (oru-diagnose);
;;;   2. the diagnosis calls for the swap the scene declares for that array (oru-plan-swap):
;;;      the task is scheduled ?*oru-prep-s* after it;
;;;   3. each step of the swap (travel, park, grasp, remove, set-down, take-spare, install,
;;;      return, unpark) is asked for by its rule once the observed state allows it, one at a
;;;      time: (robosim oru-do RULE STEP REASON). The study's geometry executes the step with
;;;      its collision checks and answers (oru-accepted (step S)) or (oru-refused (step S)
;;;      (reason R)); the sequence is oru-next;
;;;   4. a refused step is replanned: a refused set-down stows the failed ORU at the alternate
;;;      site (robosim oru-replan …); otherwise the step is retried after ?*oru-retry-s*, and
;;;      after ?*oru-retries* retries the swap is halted and reported (oru-report-blocked).
;;; Every decision is a call (robosim oru-decide|oru-schedule|oru-do|oru-replan RULE …
;;; REASON) the study records with the rule's name and reason.

(defglobal
  ?*oru-drop* = 0.2        ; the share short of the expected power that counts (assumed)
  ?*oru-persist* = 3       ; sunlit steps in a row short before the diagnosis (assumed)
  ?*oru-prep-s* = 600.0    ; from the diagnosis to the servicer's start, s (assumed)
  ?*oru-retry-s* = 900.0   ; wait before a refused step is asked for again, s (assumed)
  ?*oru-retries* = 2)      ; retries of a refused step before the swap is halted

;;; observations (retracted and asserted afresh every study step)
(deftemplate oru-now (slot t) (slot step))
(deftemplate oru-array (slot name) (slot serviced) (slot parked) (slot sunlit) (slot power-kw)
  (slot expected-kw))
(deftemplate oru-servicer (slot busy) (slot pose))
(deftemplate oru-unit (slot which) (slot where))
;;; asserted once by the study: the swap the scene declares (array carrying the ORU, spare)
(deftemplate oru-swap-declared (slot array) (slot spare))
;;; the study's answers to (robosim oru-do …)
(deftemplate oru-accepted (slot step))
(deftemplate oru-refused (slot step) (slot reason))
;;; the rules' own state
(deftemplate oru-suspect (slot array) (slot count) (slot last))
(deftemplate oru-diagnosis (slot array) (slot t))
(deftemplate oru-reported (slot array))
;;; state: scheduled | running | halted | done; next: the step asked for next; pending: asked,
;;; not answered; stow: primary | alternate
(deftemplate oru-task (slot array) (slot state) (slot next) (slot start) (slot pending)
  (slot retries) (slot stow) (slot not-before))

;;; The swap's sequence.
(deffunction oru-next (?s)
  (switch ?s
    (case travel then park)
    (case park then grasp)
    (case grasp then remove)
    (case remove then set-down)
    (case set-down then take-spare)
    (case take-spare then install)
    (case install then return)
    (case return then unpark)
    (default done)))

(deffunction oru-kw (?x) (format nil "%.1f" ?x))

;;; ---------------------------------------------------------------- 1. the guard

(defrule oru-watch-array
  (oru-array (name ?a))
  (not (oru-suspect (array ?a)))
  =>
  (assert (oru-suspect (array ?a) (count 0) (last -1.0))))

(defrule oru-array-short
  (oru-now (t ?t))
  (oru-array (name ?a) (sunlit yes) (parked no) (power-kw ?p) (expected-kw ?e&:(> ?e 1.0)))
  (test (< ?p (* ?e (- 1.0 ?*oru-drop*))))
  ?s <- (oru-suspect (array ?a) (count ?n) (last ?l&:(< ?l ?t)))
  (not (oru-diagnosis (array ?a)))
  =>
  (modify ?s (count (+ ?n 1)) (last ?t)))

(defrule oru-array-normal
  (oru-now (t ?t))
  (oru-array (name ?a) (sunlit yes) (parked no) (power-kw ?p) (expected-kw ?e))
  (test (>= ?p (* ?e (- 1.0 ?*oru-drop*))))
  ?s <- (oru-suspect (array ?a) (count ?n&:(> ?n 0)))
  =>
  (modify ?s (count 0) (last ?t)))

(defrule oru-diagnose
  (oru-now (t ?t))
  (oru-suspect (array ?a) (count ?n&:(>= ?n ?*oru-persist*)))
  (oru-array (name ?a) (power-kw ?p) (expected-kw ?e))
  (not (oru-diagnosis (array ?a)))
  =>
  (assert (oru-diagnosis (array ?a) (t ?t)))
  (robosim oru-decide oru-diagnose ?a diagnosed
    (str-cat ?a " delivers " (oru-kw ?p) " kW where the power model expects " (oru-kw ?e)
             " kW at its angles: short by more than " (* 100 ?*oru-drop*) " % over " ?n
             " sunlit steps in a row, its power-system ORU has failed")))

;;; ---------------------------------------------------------------- 2. the plan

(defrule oru-plan-swap
  (oru-now (t ?t))
  (oru-diagnosis (array ?a))
  (oru-swap-declared (array ?a) (spare ?sp))
  (not (oru-task (array ?a)))
  =>
  (bind ?start (+ ?t ?*oru-prep-s*))
  (assert (oru-task (array ?a) (state scheduled) (next travel) (start ?start) (pending no)
                    (retries 0) (stow primary) (not-before ?start)))
  (robosim oru-schedule oru-plan-swap ?a ?start
    (str-cat "the diagnosis calls for the swap: the servicer replaces " ?a "'s ORU with "
             ?sp " from " ?start " s (" ?*oru-prep-s* " s to prepare)")))

(defrule oru-no-spare
  (oru-diagnosis (array ?a))
  (not (oru-swap-declared (array ?a)))
  (not (oru-reported (array ?a)))
  =>
  (assert (oru-reported (array ?a)))
  (robosim oru-decide oru-no-spare ?a unplanned
    (str-cat "no swap is declared for " ?a " (no spare ORU for it): its generation stays lost")))

;;; ---------------------------------------------------------------- 3. the steps

(defrule oru-travel
  (oru-now (t ?t))
  ?k <- (oru-task (state scheduled|running) (next travel) (pending no)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose rest))
  (oru-unit (which failed) (where on-array))
  (oru-unit (which spare) (where on-truss))
  =>
  (modify ?k (state running) (pending yes))
  (robosim oru-do oru-travel travel
    "the servicer is at rest, the failed ORU on its array and the spare on the truss: travel along the truss to the ORU site"))

(defrule oru-park
  (oru-now (t ?t))
  ?k <- (oru-task (array ?a) (state running) (next park) (pending no)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose site))
  (oru-array (name ?a) (parked no))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-park park
    (str-cat "the servicer is at the ORU site: park " ?a " at its service angle (the ORU's grapple up)")))

(defrule oru-grasp
  (oru-now (t ?t))
  ?k <- (oru-task (array ?a) (state running) (next grasp) (pending no)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose site))
  (oru-array (name ?a) (parked yes))
  (oru-unit (which failed) (where on-array))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-grasp grasp
    (str-cat ?a " is parked and the failed ORU on its mount: reach over it, grasp it and release its bolts")))

(defrule oru-remove
  (oru-now (t ?t))
  ?k <- (oru-task (state running) (next remove) (pending no) (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose oru))
  (oru-unit (which failed) (where held))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-remove remove
    "the failed ORU is in the grip at its mount: lift it out and carry it over the truss"))

(defrule oru-set-down
  (oru-now (t ?t))
  ?k <- (oru-task (state running) (next set-down) (pending no) (stow ?w)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no))
  (oru-unit (which failed) (where held))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-set-down set-down
    (str-cat "the failed ORU is carried over the truss: set it down at the " ?w " stowage site")))

(defrule oru-take-spare
  (oru-now (t ?t))
  ?k <- (oru-task (state running) (next take-spare) (pending no) (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose above-stow))
  (oru-unit (which failed) (where set-down))
  (oru-unit (which spare) (where on-truss))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-take-spare take-spare
    "the failed ORU is set down and the grip free: move over the spare and take it"))

(defrule oru-install
  (oru-now (t ?t))
  ?k <- (oru-task (array ?a) (state running) (next install) (pending no)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose above-spare))
  (oru-unit (which spare) (where held))
  (oru-array (name ?a) (parked yes))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-install install
    (str-cat "the spare is in the grip and " ?a " still parked: carry the spare out, insert and bolt it")))

(defrule oru-return
  (oru-now (t ?t))
  ?k <- (oru-task (state running) (next return) (pending no) (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose oru))
  (oru-unit (which spare) (where bolted))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-return return
    "the spare is bolted on the mount: withdraw, fold and return along the truss"))

(defrule oru-unpark
  (oru-now (t ?t))
  ?k <- (oru-task (array ?a) (state running) (next unpark) (pending no)
                  (not-before ?nb&:(<= ?nb ?t)))
  (oru-servicer (busy no) (pose rest))
  (oru-unit (which spare) (where bolted))
  (oru-array (name ?a) (parked yes))
  =>
  (modify ?k (pending yes))
  (robosim oru-do oru-unpark unpark
    (str-cat "the servicer is back at rest, clear of " ?a "'s sweep: " ?a " tracks the sun again")))

(defrule oru-done
  (oru-now (t ?t))
  ?k <- (oru-task (array ?a) (state running) (next done))
  (oru-array (name ?a) (parked no) (power-kw ?p) (expected-kw ?e))
  (oru-unit (which spare) (where bolted))
  =>
  (modify ?k (state done))
  (robosim oru-decide oru-done ?a swapped
    (str-cat "the spare is bolted and " ?a " tracks again: " (oru-kw ?p) " kW of "
             (oru-kw ?e) " kW expected")))

;;; The study executed the step: the next one is due, asked for on a fresh observation (the
;;; step's motion starts at the next sample).
(defrule oru-step-accepted
  (declare (salience 20))
  (oru-now (t ?t) (step ?dt))
  ?a <- (oru-accepted (step ?s))
  ?k <- (oru-task (next ?s) (pending yes))
  =>
  (retract ?a)
  (modify ?k (next (oru-next ?s)) (pending no) (retries 0) (not-before (+ ?t ?dt))))

;;; ---------------------------------------------------------------- 4. refusals

;;; The stowage site is blocked: the failed ORU goes to the alternate site (the study solves
;;; the servicer's poses for it; refused again, the step is retried and then reported).
(defrule oru-replan-stow
  (declare (salience 20))
  ?r <- (oru-refused (step set-down) (reason ?why))
  ?k <- (oru-task (next set-down) (pending yes) (stow primary))
  =>
  (retract ?r)
  (modify ?k (pending no) (stow alternate))
  (robosim oru-replan oru-replan-stow alternate
    (str-cat "set-down refused (" ?why "): the failed ORU is to be stowed at the alternate site")))

(defrule oru-retry
  (declare (salience 10))
  (oru-now (t ?t))
  ?r <- (oru-refused (step ?s) (reason ?why))
  ?k <- (oru-task (next ?s) (pending yes) (retries ?n&:(< ?n ?*oru-retries*)))
  =>
  (retract ?r)
  (modify ?k (pending no) (retries (+ ?n 1)) (not-before (+ ?t ?*oru-retry-s*)))
  (robosim oru-decide oru-retry ?s wait
    (str-cat ?s " refused (" ?why "): asked again at " (+ ?t ?*oru-retry-s*) " s (retry "
             (+ ?n 1) " of " ?*oru-retries* ")")))

(defrule oru-report-blocked
  (declare (salience 10))
  ?r <- (oru-refused (step ?s) (reason ?why))
  ?k <- (oru-task (array ?a) (next ?s) (pending yes) (retries ?n&:(>= ?n ?*oru-retries*)))
  =>
  (retract ?r)
  (modify ?k (state halted) (pending no))
  (robosim oru-decide oru-report-blocked ?s halted
    (str-cat ?s " refused after " ?n " retries (" ?why "): the swap is halted where it stands, "
             ?a " keeps its failed ORU; the path must be cleared by the operators")))

(defrule oru-report-errors
  (robosim-error (command ?c) (message ?m))
  =>
  (printout t "oru_swap: (robosim " ?c ") failed: " ?m crlf))
