;;; joint_guard.clp — a guard for a session's robots (robosim rules, docs/rules.md).
;;;
;;; 1. Soft joint limits: a joint committed past its soft limit (by a planner, a script, the
;;;    editor) is set back to the limit in the next transaction, and the event is kept.
;;; 2. Contact alarms: when the simulator reports a contact for a robot, the simulator is paused
;;;    (the seed's isolate step), and the robot is commanded back to the last joints the guard
;;;    saw it at without contact (the reconfiguration step).
;;;
;;; Facts mirrored by the bridge: space, robot, joint, instance, sim, sim-robot, alarm.

(deftemplate soft-limit (slot robot) (slot index) (slot lo) (slot hi))
(deftemplate guard-event (slot robot) (slot index) (slot from) (slot to) (slot version))
(deftemplate clear-pose (slot robot) (multislot q))
(deftemplate contact-handled (slot robot))

;;; The surgical positioner's waist may not swing more than 0.8 rad either way near the head.
(deffacts positioner-soft-limits
  (soft-limit (robot positioner) (index 0) (lo -0.8) (hi 0.8)))

(defrule soft-limit-high
  (soft-limit (robot ?r) (index ?i) (hi ?hi))
  (joint (robot ?r) (index ?i) (q ?q&:(> ?q ?hi)))
  =>
  (bind ?v (robosim set-joint ?r ?i ?hi))
  (printout t "joint_guard: " ?r " joint " ?i " at " ?q " is past " ?hi "; set back at version " ?v crlf)
  (assert (guard-event (robot ?r) (index ?i) (from ?q) (to ?hi) (version ?v))))

(defrule soft-limit-low
  (soft-limit (robot ?r) (index ?i) (lo ?lo))
  (joint (robot ?r) (index ?i) (q ?q&:(< ?q ?lo)))
  =>
  (bind ?v (robosim set-joint ?r ?i ?lo))
  (printout t "joint_guard: " ?r " joint " ?i " at " ?q " is past " ?lo "; set back at version " ?v crlf)
  (assert (guard-event (robot ?r) (index ?i) (from ?q) (to ?lo) (version ?v))))

;;; Remember where each robot was last seen clear: the committed joints of a version the
;;; simulator has stepped with (joints committed since are not known to be clear yet).
(defrule remember-clear-pose
  (space (version ?v))
  (sim-robot (name ?r) (contact no) (version ?v))
  (robot (name ?r) (dof ?n))
  =>
  (bind ?q (create$))
  (do-for-all-facts ((?j joint)) (eq ?j:robot ?r)
    (bind ?q (create$ ?q ?j:q)))
  (do-for-all-facts ((?c clear-pose)) (eq ?c:robot ?r) (retract ?c))
  (assert (clear-pose (robot ?r) (q ?q))))

(defrule contact-alarm
  (alarm (source ?r) (kind contact) (message ?m))
  (not (contact-handled (robot ?r)))
  (clear-pose (robot ?r) (q $?q))
  =>
  (printout t "joint_guard: contact alarm on " ?r "; pausing the simulator and backing off" crlf)
  (robosim sim "{\"cmd\": \"pause\"}")
  (bind ?v (robosim set-joints ?r (expand$ ?q)))
  (assert (contact-handled (robot ?r))))

(defrule contact-cleared
  ?h <- (contact-handled (robot ?r))
  (not (alarm (source ?r) (kind contact)))
  =>
  (retract ?h))

(defrule report-errors
  (robosim-error (command ?c) (message ?m))
  =>
  (printout t "joint_guard: (robosim " ?c ") failed: " ?m crlf))
