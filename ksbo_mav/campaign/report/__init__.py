"""The campaign's report, read back from its directory: the flown trials as rows (:mod:`.rows`), the plots
(:mod:`.plots`, and the vehicle's changing condition in :mod:`.conditions`), the page (:mod:`.page`) and the writer
that draws them all and says where the search box capped the result (:mod:`.writer`).

Only the end of a campaign and the commands that show a campaign import this package; the flying code does not.
"""
